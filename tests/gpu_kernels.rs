//! Parity tests generated per kernel from its description
//! ([`strandfit::kernels::Kernel`]): every declared kernel, in every
//! configuration it declares, in `f32` and (where the adapter has it)
//! `f64`, runs its own random batch ([`Kernel::parity_batch`]) on the GPU
//! and through its CPU twin, and the outputs agree within the kernel's
//! stated tolerance ([`Kernel::PARITY_EPS`]). The list below must name
//! every declared kernel (checked without a GPU), and
//! `tests/shaders_validate.rs` checks that the declared kernels are the
//! files of `shaders/`: a new kernel cannot ship without its parity test.

mod common;

use strandfit::gpu::{GpuContext, Precision, Timings};
use strandfit::kernels::{parity_check, Data, Exec, Kernel, Rng, Twin};
use strandfit::twin::Real;

fn outputs<K: Kernel, R: Real, E: Exec>(exec: &E, cfg: K::Config, seed: u64) -> Data<'static, R> {
    let (batch, resident) = K::parity_batch::<R>(cfg, &mut Rng::new(seed));
    assert!(
        batch.counts.iter().any(|&c| c > 0),
        "{}: an empty parity batch",
        K::NAME
    );
    let resident: Vec<E::Resident<R>> = resident
        .into_iter()
        .map(|d| exec.resident(d).unwrap())
        .collect();
    let resident: Vec<&E::Resident<R>> = resident.iter().collect();
    let mut out = None;
    exec.run::<K, R>(
        cfg,
        &resident,
        &mut std::iter::once(batch),
        &mut |_, o| {
            out = Some(match o {
                Data::Real(v) => Data::Real(v.to_vec().into()),
                Data::U32(v) => Data::U32(v.to_vec().into()),
            })
        },
        &mut Timings::default(),
    )
    .unwrap();
    out.expect("one output")
}

fn parity_in<K: Kernel, R: Real>(ctx: &GpuContext) {
    let gpu = ctx.exec(Precision::of::<R>()).unwrap();
    for cfg in K::configs() {
        for seed in 0..3 {
            let g = outputs::<K, R, _>(&gpu, cfg, seed);
            let t = outputs::<K, R, _>(&Twin::<R>::new(), cfg, seed);
            let worst = parity_check::<K, R>(&g, &t).unwrap_or_else(|e| panic!("{cfg:?}: {e}"));
            eprintln!(
                "{} {cfg:?} ({}), seed {seed}: {} outputs, worst {worst:.2} ε (allowed {})",
                K::NAME,
                R::WGSL,
                g.len(),
                K::PARITY_EPS
            );
        }
    }
}

fn parity<K: Kernel>(test: &str) {
    let Some(ctx) = common::gpu_or_skip(test) else {
        return;
    };
    parity_in::<K, f32>(&ctx);
    if ctx.supports_f64() {
        parity_in::<K, f64>(&ctx);
    } else {
        eprintln!("{test}: adapter has no SHADER_F64; f64 parity not applicable");
    }
}

macro_rules! parity_tests {
    ($($name:ident: $k:ty),* $(,)?) => {
        $(
            #[test]
            fn $name() {
                parity::<$k>(concat!("kernel_parity_", stringify!($name)));
            }
        )*

        /// The kernels with a generated test above.
        const TESTED: &[&str] = &[$(<$k as Kernel>::NAME),*];
    };
}

parity_tests! {
    arc_check: strandfit::kernels::arc_check::ArcCheck,
    atph_hermite: strandfit::kernels::atph_hermite::AtphHermite,
    frenet_integrate: strandfit::kernels::frenet_integrate::FrenetIntegrate,
    ghosh_bisect: strandfit::kernels::ghosh_bisect::GhoshBisect,
    helix_eval: strandfit::kernels::helix_eval::HelixEval,
    spline_sample: strandfit::kernels::spline_sample::SplineSample,
}

#[test]
fn every_declared_kernel_has_a_parity_test() {
    let mut declared = strandfit::kernels::names();
    declared.sort_unstable();
    let mut tested = TESTED.to_vec();
    tested.sort_unstable();
    assert_eq!(
        declared, tested,
        "add the new kernel to parity_tests! above"
    );
}

#[test]
fn parity_batches_are_deterministic_and_the_twin_runs_them() {
    // Without a GPU: every kernel's batch, run by the twin twice, is the
    // same (the generated tests compare like with like).
    fn check<K: Kernel>() {
        for cfg in K::configs() {
            let a = outputs::<K, f32, _>(&Twin::<f32>::new(), cfg, 7);
            let b = outputs::<K, f32, _>(&Twin::<f32>::new(), cfg, 7);
            assert!(!a.is_empty(), "{}", K::NAME);
            assert_eq!(parity_check::<K, f32>(&a, &b), Ok(0.0));
        }
    }
    macro_rules! all {
        ($($k:ty),*) => { $(check::<$k>();)* };
    }
    strandfit::for_each_kernel!(all);
}

#[test]
fn parity_check_lets_a_count_move_by_its_slack_and_nothing_else() {
    // Without a GPU: the Ghosh bisection's step count (output 11 of each
    // 12-value record) may differ by two steps; a third, or any real value
    // 100 ε off, is an error that names the output.
    use strandfit::kernels::ghosh_bisect::GhoshBisect;
    let twin = outputs::<GhoshBisect, f32, _>(&Twin::<f32>::new(), (), 0);
    let with = |index: usize, delta: f32| {
        let mut v = twin.reals().to_vec();
        v[index] += delta;
        Data::<f32>::Real(v.into())
    };
    let steps = 7 * 12 + 11;
    assert!(twin.reals()[steps] > 10.0, "a bisection ran");
    assert_eq!(
        parity_check::<GhoshBisect, f32>(&with(steps, 1.0), &twin),
        Ok(0.0)
    );
    assert_eq!(
        parity_check::<GhoshBisect, f32>(&with(steps, -2.0), &twin),
        Ok(0.0)
    );
    let err = parity_check::<GhoshBisect, f32>(&with(steps, 3.0), &twin).unwrap_err();
    assert!(err.contains("output 95 (a count)"), "{err}");
    let phi = 7 * 12 + 1;
    let big = 100.0 * f32::EPSILON * twin.reals()[phi].abs().max(1.0);
    let err = parity_check::<GhoshBisect, f32>(&with(phi, big), &twin).unwrap_err();
    assert!(err.contains("output 85"), "{err}");
}
