//! The kernel as SPIR-V in which every floating-point operation is exact as written: the
//! parity path for hardware drivers (docs/gpu.md).
//!
//! naga's SPIR-V carries no `NoContraction` decoration, so a Vulkan driver may fuse
//! `a * b + c` into one FMA (one rounding instead of two) and reassociate sums. NVIDIA's
//! compiler does: on an H100 the f64 kernel left the CPU's lanes by 4e-14 m in the first
//! forcing period (docs/gpu.md). SPIR-V 1.0 section 3.20 defines `NoContraction` as
//! "apply to an arithmetic instruction to indicate the operation cannot be combined with
//! another instruction to form a single operation", the decoration GLSL's `precise`
//! compiles to, which drivers must honour. So the kernel is compiled here with naga (the
//! same front end and validator as wgpu's WGSL path, and wgpu's own bounds-check and
//! loop-bounding options for Vulkan), every result of a floating-point arithmetic
//! instruction is decorated `NoContraction`, and the words go to the driver through
//! wgpu's SPIR-V passthrough (`Features::PASSTHROUGH_SHADERS`, Vulkan only).
//!
//! What the decoration cannot reach: the precision of `OpFDiv` and `sqrt` is the
//! driver's (Vulkan requires correct rounding only for + - *), so bit-identity with
//! the CPU holds by construction only where the driver divides and takes square roots
//! correctly rounded; `tests/mirror` checks each function on the adapter at hand.

use wgpu::naga;
use wgpu::naga::back::spv;

/// SPIR-V opcodes (SPIR-V 1.6 specification, section 3.52) this module reads or writes.
mod op {
    pub const DECORATE: u16 = 71;
    /// Opcodes of floating-point arithmetic instructions whose result id is word 2
    /// (section 3.52.13, "Arithmetic Instructions", the float ones). The integer
    /// instructions have opcodes of their own, so every one of these is a float operation.
    pub const FLOAT_ARITHMETIC: [u16; 14] = [
        127, // OpFNegate
        129, // OpFAdd
        131, // OpFSub
        133, // OpFMul
        136, // OpFDiv
        140, // OpFRem
        141, // OpFMod
        142, // OpVectorTimesScalar
        143, // OpMatrixTimesScalar
        144, // OpVectorTimesMatrix
        145, // OpMatrixTimesVector
        146, // OpMatrixTimesMatrix
        147, // OpOuterProduct
        148, // OpDot
    ];
    /// Instructions of the module's layout sections 1-9 (section 2.4) that come before
    /// the annotations' end: capabilities, extensions, imports, memory model, entry
    /// points, execution modes, debug instructions and the annotations themselves.
    pub const PREAMBLE: [u16; 21] = [
        17,   // OpCapability
        10,   // OpExtension
        11,   // OpExtInstImport
        14,   // OpMemoryModel
        15,   // OpEntryPoint
        16,   // OpExecutionMode
        331,  // OpExecutionModeId
        7,    // OpString
        4,    // OpSourceExtension
        3,    // OpSource
        2,    // OpSourceContinued
        5,    // OpName
        6,    // OpMemberName
        330,  // OpModuleProcessed
        71,   // OpDecorate
        72,   // OpMemberDecorate
        332,  // OpDecorateId
        73,   // OpDecorationGroup
        74,   // OpGroupDecorate
        75,   // OpGroupMemberDecorate
        5632, // OpDecorateString
    ];
}

/// `Decoration` operand of `NoContraction` (section 3.20).
const NO_CONTRACTION: u32 = 42;

/// Words of the module header (magic, version, generator, id bound, schema).
const HEADER_WORDS: usize = 5;

/// The SPIR-V magic number, in the module's first word.
const MAGIC: u32 = 0x0723_0203;

/// Compiles a validated naga module's compute entry point `entry` to SPIR-V 1.3 with
/// wgpu's Vulkan bounds checks (index and buffer accesses clamped) but without its loop
/// bounding, then marks every floating-point arithmetic result `NoContraction` (see the
/// module docs).
///
/// Loop bounding (`force_loop_bounding`) guards against a driver deleting a loop that
/// never ends, which LLVM-based compilers may treat as undefined behaviour; it costs
/// every loop a Function-storage `vec2<u32>` counter, set and tested each iteration
/// (gfx-rs/wgpu issues 7116 and 7698). Every loop of the kernels is finite by
/// construction: the counted loops over the state are written out (`crate::unroll`),
/// the loop budget probe and the switch search's passes have constant or uniform
/// bounds, and each iteration of the sub-step loop records a period or takes a sub-step
/// of a macro step, which either advances the step's fraction by at least 1/R or flips
/// the contact mode (at most `max_segments` times before the cap's step ends it).
///
/// `bindings` are the WGSL binding numbers of group 0 in the pipeline's layout. wgpu's
/// Vulkan backend numbers a bind group's descriptors 0, 1, 2... in the order of their
/// WGSL bindings (wgpu-hal `create_bind_group_layout`, after wgpu-core sorts the entries)
/// and rewrites the shader to match; passthrough SPIR-V is not rewritten, so the same
/// numbering is written here.
pub fn exact_compute_words(
    module: &naga::Module,
    info: &naga::valid::ModuleInfo,
    entry: &str,
    bindings: &[u32],
) -> Result<Vec<u32>, String> {
    compute_words(module, info, entry, bindings, false)
}

/// [`exact_compute_words`], its loops bounded by naga's counters or not.
fn compute_words(
    module: &naga::Module,
    info: &naga::valid::ModuleInfo,
    entry: &str,
    bindings: &[u32],
    force_loop_bounding: bool,
) -> Result<Vec<u32>, String> {
    let mut sorted = bindings.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let binding_map = sorted
        .iter()
        .enumerate()
        .map(|(vk, &b)| {
            (
                naga::ResourceBinding {
                    group: 0,
                    binding: b,
                },
                spv::BindingInfo {
                    descriptor_set: 0,
                    binding: vk as u32,
                    binding_array_size: None,
                },
            )
        })
        .collect();
    let restrict = naga::proc::BoundsCheckPolicy::Restrict;
    let options = spv::Options {
        lang_version: (1, 3),
        flags: spv::WriterFlags::empty(),
        bounds_check_policies: naga::proc::BoundsCheckPolicies {
            index: restrict,
            buffer: restrict,
            image_load: restrict,
            binding_array: naga::proc::BoundsCheckPolicy::Unchecked,
        },
        force_loop_bounding,
        binding_map,
        ..Default::default()
    };
    let pipeline = spv::PipelineOptions {
        shader_stage: naga::ShaderStage::Compute,
        entry_point: entry.to_string(),
    };
    let mut words = spv::write_vec(module, info, &options, Some(&pipeline))
        .map_err(|e| format!("naga cannot write SPIR-V for {entry}: {e}"))?;
    decorate_no_contraction(&mut words)?;
    Ok(words)
}

/// The instructions of a module after its header, as (offset, opcode, word count).
fn instructions(words: &[u32]) -> Result<Vec<(usize, u16, usize)>, String> {
    if words.len() < HEADER_WORDS || words[0] != MAGIC {
        return Err("not a SPIR-V module (bad magic number)".into());
    }
    let mut out = Vec::new();
    let mut at = HEADER_WORDS;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        let opcode = (words[at] & 0xffff) as u16;
        if count == 0 || at + count > words.len() {
            return Err(format!("malformed SPIR-V instruction at word {at}"));
        }
        out.push((at, opcode, count));
        at += count;
    }
    Ok(out)
}

/// Ids that an `OpDecorate %id NoContraction` names.
fn no_contraction_targets(
    words: &[u32],
    insts: &[(usize, u16, usize)],
) -> std::collections::HashSet<u32> {
    insts
        .iter()
        .filter(|&&(at, opcode, count)| {
            opcode == op::DECORATE && count == 3 && words[at + 2] == NO_CONTRACTION
        })
        .map(|&(at, _, _)| words[at + 1])
        .collect()
}

/// Result ids of the floating-point arithmetic instructions, in module order.
fn float_results(words: &[u32], insts: &[(usize, u16, usize)]) -> Vec<u32> {
    insts
        .iter()
        .filter(|&&(_, opcode, count)| op::FLOAT_ARITHMETIC.contains(&opcode) && count >= 3)
        .map(|&(at, _, _)| words[at + 2])
        .collect()
}

/// Adds `OpDecorate %r NoContraction` for the result `%r` of every floating-point
/// arithmetic instruction, at the end of the annotation section (where the layout rules
/// of section 2.4 put decorations). Returns how many results were decorated.
pub fn decorate_no_contraction(words: &mut Vec<u32>) -> Result<usize, String> {
    let insts = instructions(words)?;
    let already = no_contraction_targets(words, &insts);
    let mut ids: Vec<u32> = float_results(words, &insts)
        .into_iter()
        .filter(|id| !already.contains(id))
        .collect();
    ids.sort_unstable();
    ids.dedup();
    let insert_at = insts
        .iter()
        .find(|&&(_, opcode, _)| !op::PREAMBLE.contains(&opcode))
        .map_or(words.len(), |&(at, _, _)| at);
    let decorations = ids
        .iter()
        .flat_map(|&id| [(3u32 << 16) | op::DECORATE as u32, id, NO_CONTRACTION]);
    words.splice(insert_at..insert_at, decorations);
    Ok(ids.len())
}

/// Counts (float arithmetic results, of them decorated `NoContraction`) in a module.
pub fn contraction_census(words: &[u32]) -> Result<(usize, usize), String> {
    let insts = instructions(words)?;
    let decorated = no_contraction_targets(words, &insts);
    let results = float_results(words, &insts);
    let n = results.iter().filter(|id| decorated.contains(id)).count();
    Ok((results.len(), n))
}

/// What a module holds that a driver is likely to keep in local (off-chip, per-thread)
/// memory rather than in registers: NVIDIA's SPIR-V front end keeps a Function-storage
/// array that is indexed with a run-time value in local memory, and naga writes an
/// array *value* indexed at run time as a copy into such a variable (its SPIR-V back
/// end's `spill_to_internal_variable`); and the counter of every loop naga bounds
/// (`force_loop_bounding`: a Function-storage `vec2<u32>` per loop, set and tested each
/// iteration). A static count of the module's words: what any driver receives.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LocalMemoryCensus {
    /// Function-storage variables whose type is an array.
    pub array_variables: usize,
    /// `OpAccessChain`s into Function-storage memory with at least one index that is
    /// not a constant.
    pub dynamic_accesses: usize,
    /// Loops (`OpLoopMerge`).
    pub loops: usize,
    /// Loop-bound counters (Function-storage `vec2<u32>` variables with an initialiser,
    /// the form naga's loop bounding declares).
    pub loop_counters: usize,
}

/// Counts what [`LocalMemoryCensus`] describes in the module `words`.
pub fn local_memory_census(words: &[u32]) -> Result<LocalMemoryCensus, String> {
    use std::collections::{HashMap, HashSet};
    const FUNCTION: u32 = 7; // StorageClass Function (section 3.7)
    let insts = instructions(words)?;
    let mut arrays: HashSet<u32> = HashSet::new(); // OpTypeArray, OpTypeRuntimeArray
    let mut uvec2: HashSet<u32> = HashSet::new(); // vec2 of a 32-bit unsigned int
    let mut u32s: HashSet<u32> = HashSet::new();
    let mut pointers: HashMap<u32, (u32, u32)> = HashMap::new(); // id -> (storage, pointee)
    let mut constants: HashSet<u32> = HashSet::new();
    let mut rooted: HashSet<u32> = HashSet::new(); // pointers into Function storage
    let mut c = LocalMemoryCensus::default();
    for &(at, opcode, count) in &insts {
        let w = |k: usize| words[at + k];
        match opcode {
            21 if count == 4 && w(2) == 32 && w(3) == 0 => {
                u32s.insert(w(1));
            }
            23 if count == 4 && u32s.contains(&w(2)) && w(3) == 2 => {
                uvec2.insert(w(1));
            }
            28 | 29 => {
                arrays.insert(w(1));
            }
            32 if count == 4 => {
                pointers.insert(w(1), (w(2), w(3)));
            }
            // OpConstantTrue/False, OpConstant, OpConstantComposite, OpConstantNull,
            // and the specialisation constants.
            41..=46 | 48..=51 => {
                constants.insert(w(2));
            }
            59 if count >= 4 && w(3) == FUNCTION => {
                rooted.insert(w(2));
                let pointee = pointers.get(&w(1)).map(|p| p.1);
                if pointee.is_some_and(|t| arrays.contains(&t)) {
                    c.array_variables += 1;
                }
                if count == 5 && pointee.is_some_and(|t| uvec2.contains(&t)) {
                    c.loop_counters += 1;
                }
            }
            // OpAccessChain, OpInBoundsAccessChain: result type, result, base, indices.
            65 | 66 if count >= 4 && rooted.contains(&w(3)) => {
                rooted.insert(w(2));
                if (4..count).any(|k| !constants.contains(&w(k))) {
                    c.dynamic_accesses += 1;
                }
            }
            246 => c.loops += 1, // OpLoopMerge
            _ => {}
        }
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader;
    use crate::shader::Variant;

    fn kernel_words<R: jeffcott_core::real::Real>(v: shader::Variant) -> Vec<u32> {
        let (module, info) = shader::validate::<R>(v, shader::capabilities::<R>(v))
            .unwrap_or_else(|e| panic!("{e}"));
        exact_compute_words(&module, &info, shader::ENTRY_POINT, &[0, 1, 2, 3, 4, 5]).unwrap()
    }

    #[test]
    fn every_float_operation_of_the_kernel_is_marked_no_contraction() {
        for (words, what) in [
            (kernel_words::<f64>(Variant::PLAIN), "f64"),
            (kernel_words::<f32>(Variant::PLAIN), "f32"),
            (
                kernel_words::<f32>(Variant::on_device(false, true)),
                "f32 through f64",
            ),
            (
                kernel_words::<f64>(Variant::on_device(true, true)),
                "f64 lyapunov",
            ),
        ] {
            let (ops, marked) = contraction_census(&words).unwrap();
            // The kernel has hundreds of float operations (RK4, the switch search...).
            assert!(ops > 200, "{what}: only {ops} float operations found");
            assert_eq!(marked, ops, "{what}: {marked} of {ops} marked");
        }
    }

    /// The SPIR-V of a small WGSL compute shader `body` (f32, no bindings), its loops
    /// bounded by naga's counters (`bounded`) or not, as the kernels are.
    fn small_words_bounded(source: &str, bounded: bool) -> Vec<u32> {
        let module = naga::front::wgsl::parse_str(source).unwrap();
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap();
        compute_words(&module, &info, "main", &[], bounded).unwrap()
    }

    fn small_words(source: &str) -> Vec<u32> {
        small_words_bounded(source, false)
    }

    #[test]
    fn the_census_finds_an_array_value_indexed_at_run_time_and_not_a_constant_index() {
        let shader = |index: &str| {
            format!(
                "var<workgroup> out: f32;
                 fn pick(a: array<f32, 4>, i: u32) -> f32 {{ return a[{index}]; }}
                 @compute @workgroup_size(1) fn main(@builtin(local_invocation_index) i: u32) {{
                     var s = 0.0;
                     for (var k = 0u; k < i; k++) {{ s += 1.0; }}
                     out = pick(array<f32, 4>(1.0, 2.0, 3.0, s), i);
                 }}"
            )
        };
        let dynamic = local_memory_census(&small_words(&shader("i"))).unwrap();
        assert_eq!(dynamic.dynamic_accesses, 1, "{dynamic:?}");
        assert_eq!(dynamic.array_variables, 1, "{dynamic:?}");
        assert_eq!(
            (dynamic.loops, dynamic.loop_counters),
            (1, 0),
            "{dynamic:?}"
        );
        // The same loop bounded as wgpu bounds it: the census sees its counter.
        let bounded = local_memory_census(&small_words_bounded(&shader("i"), true)).unwrap();
        assert_eq!(
            (bounded.loops, bounded.loop_counters),
            (1, 1),
            "{bounded:?}"
        );
        let constant = local_memory_census(&small_words(&shader("2"))).unwrap();
        assert_eq!(constant.dynamic_accesses, 0, "{constant:?}");
    }

    /// The kernel's census with its counted loops written out (`crate::unroll`), every
    /// hardware variant alike: no access into Function-storage memory at a run-time
    /// index (59 with the loops kept), six loops left (each entry form's sub-step loop,
    /// both in every module, the GPU form's lean free-flight loop, the loop budget
    /// probe, the switch search's passes and the GPU form's sample scan) and no
    /// loop-bound counter (every loop is finite by construction, see
    /// `exact_compute_words`).
    const CEILING: LocalMemoryCensus = LocalMemoryCensus {
        array_variables: 14,
        dynamic_accesses: 0,
        loops: 6,
        loop_counters: 0,
    };

    #[test]
    fn no_hardware_variant_indexes_function_storage_at_run_time_nor_bounds_a_loop_by_a_counter() {
        let variants = crate::stats::hardware_variants().unwrap();
        assert_eq!(
            variants.len(),
            36,
            "f64, f32 two ways, x lambda_1 x exact map x constants per lane, shared but the \
             speed's, shared"
        );
        for (file, label, words) in variants {
            let c = local_memory_census(&words).unwrap();
            assert!(file.ends_with(".spv") && !file.contains(' '), "{file}");
            assert_eq!(c.dynamic_accesses, 0, "{label}: {c:?}");
            assert_eq!(c.loop_counters, 0, "{label}: {c:?}");
            assert!(
                c.array_variables <= CEILING.array_variables && c.loops <= CEILING.loops,
                "{label}: {c:?} above the ceiling {CEILING:?}"
            );
        }
    }

    #[test]
    fn decorated_module_is_valid_spirv_that_naga_reads_back() {
        // naga's SPIR-V front end checks the layout (decorations before types, ids
        // defined) and reads the decoration; it must find the same entry point.
        let words = kernel_words::<f64>(Variant::PLAIN);
        let module = naga::front::spv::parse_u8_slice(
            bytemuck::cast_slice(&words),
            &naga::front::spv::Options::default(),
        );
        let module = match module {
            Ok(m) => m,
            Err(e) => panic!("naga cannot read the decorated SPIR-V back: {e}"),
        };
        assert!(
            module
                .entry_points
                .iter()
                .any(|e| e.name == shader::ENTRY_POINT)
        );
    }

    #[test]
    fn decorating_twice_adds_nothing_and_a_bad_module_is_refused() {
        let mut words = kernel_words::<f32>(Variant::PLAIN);
        let before = words.clone();
        assert_eq!(decorate_no_contraction(&mut words).unwrap(), 0);
        assert_eq!(words, before);
        let mut bad = vec![0u32; 8];
        assert!(decorate_no_contraction(&mut bad).is_err());
        // An instruction that claims more words than the module has left.
        let mut cut = before;
        cut.push((5 << 16) | 129);
        assert!(decorate_no_contraction(&mut cut).is_err());
    }
}
