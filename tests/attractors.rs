//! The article's reported responses (docs/model.md 6), reproduced from the static equilibrium.

use jeffcott_analysis::classify::{Class, ClassifyConfig};
use jeffcott_analysis::simulate::{Integrator, SimulateSpec, simulate};
use jeffcott_core::model::Params;

fn spec(omega: f64) -> SimulateSpec {
    let params = Params::default();
    SimulateSpec {
        x0: params.static_equilibrium(),
        params,
        omega,
        transient: 1000,
        periods: 64,
        timeseries_periods: 2,
        integrator: Integrator::Lane,
        stepper: Default::default(),
        article: Default::default(),
        classify: ClassifyConfig::default(),
    }
}

#[test]
fn static_equilibrium_start_settles_on_period_1_at_131_7_and_period_2_at_132_2() {
    for (omega, n) in [(131.7, 1), (132.2, 2)] {
        let res = simulate(&spec(omega)).unwrap();
        assert_eq!(res.classification.class, Class::Periodic(n), "W = {omega}");
        assert!(
            res.contact_fraction > 0.0,
            "the response rubs at W = {omega}"
        );
        // The labels hold when the tolerances change 10x either way.
        for (rel, abs) in [(1e-2, 1e-6), (1e-4, 1e-8)] {
            let mut s = spec(omega);
            s.classify = ClassifyConfig {
                rel_tol: rel,
                abs_tol: abs,
                ..ClassifyConfig::default()
            };
            let c = jeffcott_analysis::classify::classify(&res.poincare, omega, false, &s.classify);
            assert_eq!(
                c.class,
                Class::Periodic(n),
                "W = {omega}, tolerances {rel}/{abs}"
            );
        }
    }
}
