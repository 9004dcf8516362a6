//! Geometry files: a user's mesh arrives with named boundary groups
//! (Gmsh physical groups); a small TOML file binds each to an exact shape
//! and says what its nodes do.
//!
//! ```toml
//! [[group]]
//! name = "wall"                 # a physical group of the mesh
//! kind = "curve"                # curve: nodes go onto the shape
//!                               # slip: nodes glide along it (default: the wall as meshed)
//!                               # fixed: nodes stay
//! shape = { type = "circle", centre = [0.0, 0.0], radius = 0.5 }
//! # level_set = "x^2 + y^2 - 0.25"   # or the zero set of φ(x, y, z)
//! ```
//!
//! Groups of the mesh that the file does not name stay as they are.

use crate::case::CaseError;
use crate::deform::{BoundaryPart, BoundaryShape, Correspondence, MoveMode, PartKind};
use crate::expr::Expr;
use crate::geometry::ShapeSpec;
use crate::geometry3::SurfaceSpec;
use crate::jacobian::EXPR_VARS;
use serde::Deserialize;
use std::path::Path;
use std::sync::Arc;

/// The whole geometry file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeometryFile {
    /// One table per bound group.
    #[serde(default)]
    pub group: Vec<GroupSpec>,
    /// How far a node of a curved group may lie from its shape, relative
    /// to its shortest adjacent edge (see
    /// [`crate::highorder::curve::DEFAULT_SHAPE_TOLERANCE`]); raises, never
    /// lowers, the default.
    #[serde(default)]
    pub shape_tolerance: Option<f64>,
    /// The text it came from (for line numbers).
    #[serde(skip)]
    source: String,
}

/// What a group's nodes do.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum GroupKind {
    /// New high-order nodes go onto the shape.
    Curve,
    /// Nodes glide along the shape (or the wall as meshed).
    Slip,
    /// Nodes stay.
    Fixed,
}

/// One `[[group]]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroupSpec {
    /// The physical group's name in the mesh.
    pub name: String,
    /// `curve`, `slip` or `fixed`.
    pub kind: GroupKind,
    /// A curve (2D) or surface (3D) of the geometry module.
    #[serde(default)]
    pub shape: Option<toml::Spanned<toml::Value>>,
    /// Or a level set φ(x, y, z) = 0.
    #[serde(default)]
    pub level_set: Option<String>,
}

/// The zero set of φ as a boundary shape: projection by Newton's method,
/// `x ← x − φ ∇φ / |∇φ|²`, from the point itself (a foot point on the
/// surface near it: for points close to the surface, as mesh nodes are,
/// the closest one to first order).
#[derive(Clone, Debug)]
pub struct LevelSet {
    phi: Expr,
}

impl LevelSet {
    /// φ from an expression in x, y, z.
    pub fn new(phi: Expr) -> Result<LevelSet, String> {
        if phi.uses("t") {
            return Err("a level set may not use t".into());
        }
        Ok(LevelSet { phi })
    }

    fn eval<const D: usize>(&self, x: [f64; D]) -> f64 {
        let mut v = [0.0; 4];
        v[..D].copy_from_slice(&x);
        self.phi.eval(&v)
    }

    fn grad<const D: usize>(&self, x: [f64; D]) -> [f64; D] {
        let h = 1e-7 * (1.0 + x.iter().fold(0.0f64, |m, v| m.max(v.abs())));
        std::array::from_fn(|k| {
            let (mut a, mut b) = (x, x);
            a[k] += h;
            b[k] -= h;
            (self.eval(a) - self.eval(b)) / (2.0 * h)
        })
    }

    fn project<const D: usize>(&self, x: [f64; D]) -> [f64; D] {
        let mut p = x;
        for _ in 0..50 {
            let (v, g) = (self.eval(p), self.grad(p));
            let n2: f64 = g.iter().map(|c| c * c).sum();
            if !(n2 > 0.0) || !v.is_finite() {
                break;
            }
            let step: [f64; D] = std::array::from_fn(|k| v * g[k] / n2);
            p = std::array::from_fn(|k| p[k] - step[k]);
            if step.iter().map(|c| c * c).sum::<f64>().sqrt() <= 1e-15 * (1.0 + p.iter().map(|c| c * c).sum::<f64>().sqrt()) {
                break;
            }
        }
        p
    }
}

impl<const D: usize> BoundaryShape<D> for LevelSet {
    fn closest_point(&self, p: [f64; D]) -> [f64; D] {
        self.project(p)
    }
    fn distance(&self, p: [f64; D]) -> f64 {
        let q = self.project(p);
        (0..D).map(|k| (q[k] - p[k]).powi(2)).sum::<f64>().sqrt()
    }
    fn normal(&self, p: [f64; D]) -> [f64; D] {
        let g = self.grad(self.project(p));
        let l = g.iter().map(|c| c * c).sum::<f64>().sqrt();
        g.map(|c| c / l)
    }
    fn ray_hit(&self, origin: [f64; D], dir: [f64; D]) -> Option<[f64; D]> {
        // bracket the first sign change of φ along the ray on a doubling
        // grid (the gradient may vanish at the origin, a centre), then bisect
        let at = |s: f64| -> [f64; D] { std::array::from_fn(|k| origin[k] + s * dir[k]) };
        let f0 = self.eval(origin);
        let (mut lo, mut hi) = (0.0, f64::NAN);
        let mut s = 1e-6;
        for _ in 0..70 {
            let v = self.eval(at(s));
            if v == 0.0 {
                return Some(at(s));
            }
            if v.signum() != f0.signum() {
                hi = s;
                break;
            }
            lo = s;
            s *= 2.0;
        }
        if hi.is_nan() {
            return None;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if self.eval(at(mid)).signum() == f0.signum() { lo = mid } else { hi = mid }
        }
        Some(at(0.5 * (lo + hi)))
    }
}

impl GeometryFile {
    /// Reads and parses a geometry file.
    pub fn read(path: &Path) -> Result<GeometryFile, CaseError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| CaseError { file: file.clone(), message: format!("cannot read: {e}") })?;
        GeometryFile::parse(&text, &file)
    }

    /// Parses geometry text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<GeometryFile, CaseError> {
        let mut g: GeometryFile = toml::from_str(text).map_err(|e| CaseError { file: file.to_string(), message: e.to_string().trim_end().to_string() })?;
        g.source = text.to_string();
        if let Some(t) = g.shape_tolerance {
            if !(t.is_finite() && t > 0.0) {
                return Err(CaseError { file: file.to_string(), message: format!("shape_tolerance must be a positive number (a fraction of the local edge length), got {t}") });
            }
        }
        Ok(g)
    }

    fn line_of(&self, offset: usize) -> String {
        if self.source.len() < offset {
            return String::new();
        }
        format!("line {}: ", self.source[..offset].matches('\n').count() + 1)
    }

    /// The boundary parts for a mesh with groups `names` in `D`
    /// dimensions, in the mesh's part order, and the names of the groups
    /// the file leaves alone (they become fixed).
    pub fn parts<const D: usize>(&self, names: &[String], file: &str) -> Result<(Vec<BoundaryPart<D>>, Vec<String>), CaseError> {
        let err = |message: String| CaseError { file: file.to_string(), message };
        let mut kinds: Vec<Option<PartKind<D>>> = vec![None; names.len()];
        for (k, g) in self.group.iter().enumerate() {
            let here = format!("group[{k}] (`{}`)", g.name);
            let Some(i) = names.iter().position(|n| *n == g.name) else {
                return Err(err(format!("{here}: the mesh has no boundary group `{}` (it has: {})", g.name, names.join(", "))));
            };
            if kinds[i].is_some() {
                return Err(err(format!("{here}: the group `{}` is bound twice", g.name)));
            }
            let line = g.shape.as_ref().map_or(String::new(), |v| self.line_of(v.span().start));
            let shape = shape_of::<D>(g).map_err(|m| err(format!("{line}{here}: {m}")))?;
            kinds[i] = Some(match (g.kind, shape) {
                (GroupKind::Curve, Some(target)) => PartKind::Move { target, correspondence: Correspondence::Normal, mode: MoveMode::Sliding },
                (GroupKind::Curve, None) => return Err(err(format!("{here}: kind = \"curve\" needs a `shape` or a `level_set`"))),
                (GroupKind::Slip, wall) => PartKind::Slip { wall },
                (GroupKind::Fixed, None) => PartKind::Fixed,
                (GroupKind::Fixed, Some(_)) => return Err(err(format!("{here}: kind = \"fixed\" takes no shape"))),
            });
        }
        let unbound: Vec<String> = names.iter().zip(&kinds).filter(|(_, k)| k.is_none()).map(|(n, _)| n.clone()).collect();
        let parts = names.iter().zip(kinds).map(|(n, k)| BoundaryPart { name: n.clone(), kind: k.unwrap_or(PartKind::Fixed) }).collect();
        Ok((parts, unbound))
    }
}

impl GeometryFile {
    /// Fails for a group this file binds that no boundary element carries
    /// (`carried[i]`: part `i` of `names` has elements): a physical name
    /// in the mesh that no entity has elements for, which binding would
    /// silently ignore.
    pub fn check_carried(&self, names: &[String], carried: &[bool], file: &str) -> Result<(), CaseError> {
        for (k, g) in self.group.iter().enumerate() {
            if names.iter().zip(carried).any(|(n, &c)| *n == g.name && !c) {
                let message = format!(
                    "group[{k}] (`{}`): the mesh names this physical group, but no boundary element carries it (no entity of the group has elements); check the group in Gmsh",
                    g.name
                );
                return Err(CaseError { file: file.to_string(), message });
            }
        }
        Ok(())
    }
}

/// Per part, whether any boundary element carries it.
pub fn carried(parts: impl Iterator<Item = usize>, count: usize) -> Vec<bool> {
    let mut c = vec![false; count];
    for p in parts {
        if let Some(x) = c.get_mut(p) {
            *x = true;
        }
    }
    c
}

/// The shape of a group: a curve or surface spec, or a level set.
fn shape_of<const D: usize>(g: &GroupSpec) -> Result<Option<Arc<dyn BoundaryShape<D>>>, String> {
    match (&g.shape, &g.level_set) {
        (Some(_), Some(_)) => Err("give `shape` or `level_set`, not both".into()),
        (None, None) => Ok(None),
        (None, Some(text)) => {
            let e = Expr::parse(text, &EXPR_VARS).map_err(|e| format!("field `level_set`: {e}"))?;
            Ok(Some(Arc::new(LevelSet::new(e)?)))
        }
        (Some(v), None) => {
            let v = v.get_ref().clone();
            if D == 2 {
                let spec: ShapeSpec = v.try_into().map_err(|e: toml::de::Error| format!("field `shape`: {}", e.to_string().trim_end()))?;
                let s = spec.build().map_err(|e| format!("field `shape`: {e}"))?;
                Ok(Some(cast::<D, 2>(Arc::new(s))))
            } else {
                let spec: SurfaceSpec = v.try_into().map_err(|e: toml::de::Error| format!("field `shape`: {}", e.to_string().trim_end()))?;
                let s = spec.build().map_err(|e| format!("field `shape`: {e}"))?;
                Ok(Some(cast::<D, 3>(Arc::new(s))))
            }
        }
    }
}

/// A shape of dimension E as one of dimension D, where D == E is checked
/// by the caller: the const generics cannot see it.
fn cast<const D: usize, const E: usize>(s: Arc<dyn BoundaryShape<E>>) -> Arc<dyn BoundaryShape<D>> {
    assert_eq!(D, E, "dimension checked by the caller");
    Arc::new(SameDim::<E> { inner: s })
}

/// Adapts `[f64; E]` to `[f64; D]` for D == E.
#[derive(Debug)]
struct SameDim<const E: usize> {
    inner: Arc<dyn BoundaryShape<E>>,
}

fn conv<const A: usize, const B: usize>(x: [f64; A]) -> [f64; B] {
    std::array::from_fn(|i| x[i])
}

impl<const D: usize, const E: usize> BoundaryShape<D> for SameDim<E> {
    fn closest_point(&self, p: [f64; D]) -> [f64; D] {
        conv(self.inner.closest_point(conv(p)))
    }
    fn distance(&self, p: [f64; D]) -> f64 {
        self.inner.distance(conv(p))
    }
    fn normal(&self, p: [f64; D]) -> [f64; D] {
        conv(self.inner.normal(conv(p)))
    }
    fn ray_hit(&self, origin: [f64; D], dir: [f64; D]) -> Option<[f64; D]> {
        self.inner.ray_hit(conv(origin), conv(dir)).map(conv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_set_projects_onto_a_circle_and_hits_it() {
        let ls = LevelSet::new(Expr::parse("x^2 + y^2 - 0.25", &EXPR_VARS).unwrap()).unwrap();
        for p in [[0.6, 0.1], [0.3, -0.2], [-0.51, 0.0]] {
            let q = BoundaryShape::<2>::closest_point(&ls, p);
            assert!((q[0].hypot(q[1]) - 0.5).abs() < 1e-14, "{q:?}");
            // Newton's foot point lies on the ray through the centre here
            assert!((q[1] * p[0] - q[0] * p[1]).abs() < 1e-8);
        }
        let hit = BoundaryShape::<2>::ray_hit(&ls, [0.0, 0.0], [1.0, 1.0]).unwrap();
        assert!((hit[0] - 0.5 / 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn groups_bind_by_name_and_unknown_names_are_errors() {
        let names = vec!["wall".to_string(), "farfield".to_string()];
        let g = GeometryFile::parse("[[group]]\nname = \"wall\"\nkind = \"curve\"\nshape = { type = \"circle\", centre = [0.0, 0.0], radius = 0.5 }\n", "g.toml").unwrap();
        let (parts, unbound) = g.parts::<2>(&names, "g.toml").unwrap();
        assert!(matches!(parts[0].kind, PartKind::Move { .. }) && matches!(parts[1].kind, PartKind::Fixed));
        assert_eq!(unbound, vec!["farfield".to_string()]);
        let bad = GeometryFile::parse("[[group]]\nname = \"wal\"\nkind = \"fixed\"\n", "g.toml").unwrap();
        let e = bad.parts::<2>(&names, "g.toml").unwrap_err().to_string();
        assert!(e.contains("g.toml") && e.contains("`wal`") && e.contains("wall, farfield"), "{e}");
        let bad = GeometryFile::parse("[[group]]\nname = \"wall\"\nkind = \"curve\"\nshape = { type = \"circle\", centre = [0.0, 0.0], radius = -1.0 }\n", "g.toml").unwrap();
        let e = bad.parts::<2>(&names, "g.toml").unwrap_err().to_string();
        assert!(e.contains("line 4") && e.contains("radius"), "{e}");
        assert!(GeometryFile::parse("[[group]]\nname = \"wall\"\nkind = \"bend\"\n", "g.toml").unwrap_err().to_string().contains("unknown variant"));
    }

    #[test]
    fn a_group_no_element_carries_is_an_error_naming_it() {
        let names = vec!["wall".to_string(), "ghost".to_string()];
        let c = carried([0usize, 0].into_iter(), 2);
        assert_eq!(c, [true, false]);
        let g = GeometryFile::parse("[[group]]\nname = \"ghost\"\nkind = \"fixed\"\n", "g.toml").unwrap();
        let e = g.check_carried(&names, &c, "g.toml").unwrap_err().to_string();
        assert!(e.contains("g.toml") && e.contains("`ghost`") && e.contains("no boundary element carries it"), "{e}");
        let g = GeometryFile::parse("[[group]]\nname = \"wall\"\nkind = \"fixed\"\n", "g.toml").unwrap();
        g.check_carried(&names, &c, "g.toml").unwrap();
    }
}
