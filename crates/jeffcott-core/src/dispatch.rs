//! One body compiled for several x86-64 instruction sets, the fastest the CPU has chosen
//! at run time ([`per_instruction_set`]): the batch code of `ensemble::cpu` and the
//! scalar macro step of `integrate::lane`. Every copy is the same operations in the same
//! order without FMA, so the bits do not depend on the CPU (tests/avx512.rs).

/// Declares `$name`, which runs `$inner` compiled for AVX-512 where [`use_avx512`] says
/// so (`$wide`: whether this instantiation was measured faster with it on an AMD CPU),
/// else for AVX2 where the CPU has it, else as built: the same code for each
/// instruction set (no FMA: fusing would change the rounding), so the lanes' arithmetic
/// cannot drift between them. `[$gen]` are the generic parameters, `[$arg]` the
/// arguments `$inner` is instantiated with.
macro_rules! per_instruction_set {
    ($(#[$doc:meta])* $vis:vis fn $name:ident [$($gen:tt)*] [$($garg:tt)*]
     ($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty = $inner:ident, avx512_on_amd: $wide:expr) => {
        per_instruction_set! {
            @copies $(#[$doc])* $vis fn $name [$($gen)*] [$($garg)*]
            ($($arg: $ty),*) -> $ret = $inner, avx512_on_amd: $wide,
            avx512: [$($garg)*], other: [$($garg)*]
        }
    };
    // The same, with `$inner` told whether it is the AVX-512 copy (a last const
    // generic `bool`), for code with parts written for AVX-512 alone
    // (`integrate::transpose`).
    ($(#[$doc:meta])* $vis:vis fn $name:ident [$($gen:tt)*] [$($garg:tt)*]
     ($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty = $inner:ident, avx512_on_amd: $wide:expr,
     tells_avx512) => {
        per_instruction_set! {
            @copies $(#[$doc])* $vis fn $name [$($gen)*] [$($garg)*]
            ($($arg: $ty),*) -> $ret = $inner, avx512_on_amd: $wide,
            avx512: [$($garg)*, true], other: [$($garg)*, false]
        }
    };
    // The copies, `$inner` instantiated with `[$a]` in the AVX-512 one and `[$o]` in
    // the others.
    (@copies $(#[$doc:meta])* $vis:vis fn $name:ident [$($gen:tt)*] [$($garg:tt)*]
     ($($arg:ident: $ty:ty),*) -> $ret:ty = $inner:ident, avx512_on_amd: $wide:expr,
     avx512: [$($a:tt)*], other: [$($o:tt)*]) => {
        $(#[$doc])*
        $vis fn $name<$($gen)*>($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
                fn avx512<$($gen)*>($($arg: $ty),*) -> $ret {
                    $inner::<$($a)*>($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                fn avx2<$($gen)*>($($arg: $ty),*) -> $ret {
                    $inner::<$($o)*>($($arg),*)
                }
                if $crate::dispatch::use_avx512($wide) {
                    // SAFETY: the CPU has been found to support AVX-512 F, DQ and VL.
                    return unsafe { avx512::<$($garg)*>($($arg),*) };
                }
                if std::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has just been found to support AVX2.
                    return unsafe { avx2::<$($garg)*>($($arg),*) };
                }
            }
            $inner::<$($o)*>($($arg),*)
        }
    };
}

/// Whether the AVX-512 copy runs, for code that `wide` says ran faster with it on the
/// CPU families measured: where the CPU has AVX-512 F, DQ and VL, `JEFFCOTT_AVX512=1` or
/// `0` decides; unset, AVX-512 runs for such code on the families where it was measured
/// faster, decided by family rather than vendor ([`family_takes_avx512`]). Either build
/// gives the same bits (tests/avx512.rs).
#[cfg(target_arch = "x86_64")]
pub(crate) fn use_avx512(wide: bool) -> bool {
    static CHOICE: std::sync::OnceLock<(bool, Option<bool>)> = std::sync::OnceLock::new();
    let (eligible, forced) = *CHOICE.get_or_init(|| {
        let has = std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512dq")
            && std::is_x86_feature_detected!("avx512vl");
        let forced = match std::env::var_os("JEFFCOTT_AVX512") {
            Some(v) if v == "1" => Some(true),
            Some(v) if v == "0" => Some(false),
            _ => None,
        };
        (has && (forced.is_some() || family_takes_avx512()), forced)
    });
    eligible && forced.unwrap_or(wide)
}

/// Whether the CPU belongs to a family on which the 512-bit batches were measured
/// faster than AVX2 (the basin at 133 rad/s, the standard job, `jeffcott bench`):
///
/// | family | how it is told | AVX-512 against AVX2 |
/// |---|---|---|
/// | AMD Zen 4 and Zen 5 (EPYC) | vendor AMD with AVX-512 | faster: grouped batches 1.6 % (f64) and 6 % (f32), refilled batches 36 % on a basin |
/// | Intel Ice Lake and later (Xeon with IFMA and VBMI) | vendor Intel, AVX-512 IFMA and VBMI | faster: basin at 133 rad/s 17.4 / 16.5 s against 18.8 / 21.3 s, the standard job 43.7k against 32.0k lane-periods/s |
/// | Intel Skylake-SP and Cascade Lake (AVX-512 without IFMA) | the rest | not measured since the transposes were written in AVX-512 shuffles (8 % slower before); AVX2 kept, as those cores lower their clock for 512-bit work |
#[cfg(target_arch = "x86_64")]
fn family_takes_avx512() -> bool {
    cpu_is_amd()
        || (std::is_x86_feature_detected!("avx512ifma")
            && std::is_x86_feature_detected!("avx512vbmi"))
}

/// Whether the CPU's vendor string (CPUID leaf 0) is AMD's.
#[cfg(target_arch = "x86_64")]
fn cpu_is_amd() -> bool {
    // SAFETY: CPUID leaf 0 exists on every x86-64 CPU.
    #[allow(unused_unsafe)]
    let r = unsafe { std::arch::x86_64::__cpuid(0) };
    let mut vendor = [0u8; 12];
    for (chunk, w) in vendor.chunks_exact_mut(4).zip([r.ebx, r.edx, r.ecx]) {
        chunk.copy_from_slice(&w.to_le_bytes());
    }
    &vendor == b"AuthenticAMD"
}
