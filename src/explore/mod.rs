//! `jeffcott explore`: a local web server and the page it serves, for finding the
//! interesting corners of a rub problem by looking: a bifurcation diagram whose zoom
//! recomputes the region (as InteractiveDynamics.jl's `interactive_orbitdiagram` does
//! for maps), a basin whose zoom recomputes its fractal boundary, and a click that
//! opens one lane's trajectory with its attractor and Floquet multipliers.
//!
//! The server ([`Explorer`]) is synchronous (`tiny_http`): each request is a thread
//! that computes one slice of a view on the engine opened at start and answers it
//! whole; the page asks for the slices in turn (coarse to fine), so a zoom's first
//! pixels come after one small slice and a stale request is cancelled by the next one
//! of the same page and view ([`work::Work`]). Security: loopback only unless a host is
//! given, and then every request must carry the token printed at start; no request
//! names a file; sizes are bounded (the URL, the body, every field of [`views`]).

mod http;
pub mod query;
pub mod views;
pub mod work;

pub use http::{Explorer, ExplorerConfig};
