//! Reading and writing meshes: what a file holds besides the cells
//! ([`layout`]), Gmsh MSH 4.1 and 2.2 ([`msh`]), MFEM mesh v1.0
//! ([`mfem`]), ABAQUS as HOHQMesh writes it for Trixi.jl ([`abaqus`]) and
//! VTK XML unstructured grids ([`vtu`]), for meshes of any order.

/// Appends one formatted line to a `String`. Formatting into a `String`
/// cannot fail, so the `fmt::Result` is dropped here once for all writers.
macro_rules! put {
    ($out:expr, $($arg:tt)*) => {
        let _ = writeln!($out, $($arg)*);
    };
}

pub mod abaqus;
pub mod folder;
pub mod layout;
pub mod mfem;
pub mod msh;
pub mod vtu;

/// Formats an `f64` so that parsing the text gives back the same bits.
///
/// Rust's `{}` and `{:e}` both print the shortest round-trip digits; `{}`
/// never switches to an exponent, which would spell out 1e300 in full, so
/// values far from 1 use the exponent form.
pub(crate) fn fmt_f64(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-5..1e16).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fmt_f64_round_trips_bit_exactly() {
        let values = [
            0.0,
            -0.0,
            1.0,
            0.1,
            -2.5e-7,
            1e300,
            -1e-300,
            f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            std::f64::consts::PI,
            123456789.12345679,
        ];
        for x in values {
            let s = fmt_f64(x);
            let back: f64 = s.parse().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{x} printed as {s}");
        }
        assert_eq!(fmt_f64(1e300), "1e300");
    }
}
