//! The right-hand side of a batch's lanes (`model::rhs_frozen` per lane, contact mode
//! per lane): the article's model, the machine's offset and directional terms, and each
//! lane's contact law, with the bits of the scalar definitions.

use super::{BATCH, BatchConsts, V, lane_of, set_lane};
use crate::integrate::wide::Wide;
use crate::model::{
    STATE_DIM, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S, concentric, contact_force_law_powered,
    contact_force_per_kc, relative_motion, rhs_with_force,
};
use crate::real::Real;

/// `model::rhs_frozen` for every lane (contact mode per lane).
#[inline(always)]
pub(super) fn rhs<R: Real>(
    bc: &BatchConsts<R>,
    x: &[V<R>; STATE_DIM],
    cos_phase: &V<R>,
    sin_phase: &V<R>,
    contact: &[bool; BATCH],
) -> [V<R>; STATE_DIM] {
    // Three instantiations, chosen once a batch: the article's model; the offset and
    // directional terms on, where some lane uses one; and also each lane's contact law,
    // where some lane's contact is not the linear spring. A lane without a term keeps
    // its bits (`model::rhs_with_force`, [`law_forces`]). One instantiation per
    // combination of the terms (eight) multiplied the code inlined into every stepper.
    match (bc.machine, bc.terms.contact_law) {
        (false, _) => rhs_lanes::<R, false, false>(bc, x, cos_phase, sin_phase, contact),
        (true, false) => rhs_lanes::<R, true, false>(bc, x, cos_phase, sin_phase, contact),
        (true, true) => rhs_lanes::<R, true, true>(bc, x, cos_phase, sin_phase, contact),
    }
}

/// [`rhs`] for the article's model (`MACHINE` off: a centred stator and isotropic
/// supports) or with the stator's offset subtracted and the y coefficients read
/// (docs/model.md 7); with each lane's own contact law ([`law_forces`], `LAW`) or the
/// linear spring for all.
#[inline(always)]
fn rhs_lanes<R: Real, const MACHINE: bool, const LAW: bool>(
    bc: &BatchConsts<R>,
    x: &[V<R>; STATE_DIM],
    cos_phase: &V<R>,
    sin_phase: &V<R>,
    contact: &[bool; BATCH],
) -> [V<R>; STATE_DIM] {
    let mut f = [[R::lit(0.0); BATCH]; STATE_DIM];
    // Without a lane in contact the force is not computed at all (the same zeros).
    let any_contact = contact.iter().any(|&c| c);
    // The contact laws' forces before the loop: in it, a lane's choice of law kept the
    // loop from vectorising (1.6x the linear law's instructions a lane-step).
    let law = if LAW && any_contact {
        law_forces(bc, x, contact)
    } else {
        ([R::lit(0.0); BATCH], [R::lit(0.0); BATCH])
    };
    for l in 0..BATCH {
        let c = bc.c.lane(l);
        // The force of every lane, kept where the lane is in contact (branch-free, so
        // the loop vectorises); then `model::rhs_with_force`, the scalar definition.
        let (fx, fy) = if LAW {
            (law.0[l], law.1[l])
        } else if any_contact {
            let d = [
                x[X_R][l] - x[X_S][l],
                x[Y_R][l] - x[Y_S][l],
                x[VX_R][l] - x[VX_S][l],
                x[VY_R][l] - x[VY_S][l],
            ];
            let (kx, ky) = contact_force_per_kc(c.delta, c.mu, c.tau_c, d[0], d[1], d[2], d[3]);
            if contact[l] {
                (kx, ky)
            } else {
                (R::lit(0.0), R::lit(0.0))
            }
        } else {
            (R::lit(0.0), R::lit(0.0))
        };
        let fl = rhs_with_force::<R, MACHINE, MACHINE>(
            &c,
            &lane_of(x, l),
            cos_phase[l],
            sin_phase[l],
            fx,
            fy,
        );
        set_lane(&mut f, l, fl);
    }
    f
}

/// `model::contact_force_lane` for every lane, kept where the lane is in contact (zero
/// elsewhere): the general law on the whole batch (`Wide`, branch-free) and picked per
/// lane by selects, the linear law per lane where a batch mixes the two, so every lane
/// has the bits of the scalar definition.
#[inline(always)]
fn law_forces<R: Real>(
    bc: &BatchConsts<R>,
    x: &[V<R>; STATE_DIM],
    contact: &[bool; BATCH],
) -> (V<R>, V<R>) {
    let [dx, dy, dvx, dvy] = relative_motion(&x.map(Wide));
    let c = bc.c.wide();
    // The law's power of the gap without a square root where every exponent is whole
    // (n = 1, 2 or 3: the same bits, `model::pow_whole`).
    let (gx, gy) = if bc.law_root {
        contact_force_law_powered::<_, true>(&c, dx, dy, dvx, dvy)
    } else {
        contact_force_law_powered::<_, false>(&c, dx, dy, dvx, dvy)
    };
    // The general law's lanes: in contact and not concentric. Picked by value selects,
    // not stores under a branch: per-lane branches and stores, read back as whole
    // vectors (where store-to-load forwarding fails), were the largest part of the
    // law's extra time in a profile of the bench (perf).
    let mut general = [false; BATCH];
    for l in 0..BATCH {
        general[l] = contact[l] & bc.law[l] & !concentric(dx[l], dy[l]);
    }
    let zero = Wide::same(R::lit(0.0));
    let (mut fx, mut fy) = (gx.select(&general, zero).0, gy.select(&general, zero).0);
    // The linear law where some lane in contact takes it (a table mixing the laws).
    if bc.law != [true; BATCH] {
        for l in 0..BATCH {
            if contact[l] && !bc.law[l] {
                let (delta, mu, tau_c) = (bc.c.delta[l], bc.c.mu[l], bc.c.tau_c[l]);
                (fx[l], fy[l]) =
                    contact_force_per_kc(delta, mu, tau_c, dx[l], dy[l], dvx[l], dvy[l]);
            }
        }
    }
    (fx, fy)
}
