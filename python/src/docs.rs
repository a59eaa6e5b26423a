//! Docstring items of the keywords several functions share. Every function's docstring
//! ends in a `Parameters:` list, one item per parameter in the signature's order
//! (tests/test_docs.py checks it against the type stub); the items below are written
//! once, so a keyword reads the same in every `help()`.

/// The docstring item (`- `name`: ...`) of a shared keyword, a string literal for
/// `#[doc = param_doc!(name)]`.
macro_rules! param_doc {
    (params) => {
        "- `params`: model parameters replacing Table 1's, `{key: value}` (the keys of\n  \
         `PARAM_KEYS`, or a machine's `k_r`, `c_r`, `k_s`, `c_s`, `unbalance`; SI units;\n  \
         the command line's `--param`); None: Table 1."
    };
    (init) => {
        "- `init`: start coordinates replacing the static equilibrium's, `{name: value}`\n  \
         (the names of `COORD_NAMES` [m, m/s]; the command line's `--init`)."
    };
    (backend) => {
        "- `backend`: `\"auto\"` (a hardware GPU if present, else the CPU), `\"cpu\"` or\n  \
         `\"gpu\"` (any adapter, software ones included; an error if none)."
    };
    (precision) => {
        "- `precision`: `\"f32\"` or `\"f64\"` lanes; None: f64 on the CPU, f32 on a GPU\n  \
         (f64 on a GPU needs an adapter with SHADER_F64)."
    };
    (progress) => {
        "- `progress`: a callable `f(done, total)` called as the run advances (in\n  \
         lane-periods), or None."
    };
    (stepper) => {
        "- `**stepper`: the lane stepper's settings as keywords (`steps_per_period`,\n  \
         `contact_substeps`, `exact_free_flight`, ...: the names of `STEPPER_DEFAULTS`,\n  \
         which holds their defaults; the command line's options of those names)."
    };
    // Several keywords at once, one line each, as separate `#[doc]` lines would give.
    ($first:ident, $($rest:ident),+) => {
        concat!(param_doc!($first), "\n", param_doc!($($rest),+))
    };
}
