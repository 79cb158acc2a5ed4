//! Named numerical tolerances, in one place.
//!
//! Compare relatively when the quantity has a natural scale of its own, absolutely when it can
//! pass through zero (Ei near its root, a force near t0), and never with `==`.

/// Machine epsilon of `f64`.
pub const EPS: f64 = f64::EPSILON;
