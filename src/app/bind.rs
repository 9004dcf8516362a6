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

use crate::app::case::CaseError;
use crate::deform::{BoundaryPart, Correspondence, MoveMode, PartKind};
use crate::expr::Expr;
use crate::geometry::{shape_from_toml, ClosestPoint, LevelSet};
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
        if g.group.is_empty() {
            return Err(CaseError {
                file: file.to_string(),
                message: "binds no group: `curve` would curve nothing. Add a `[[group]]` table per group to curve (name, kind = \"curve\", shape) or to slide (kind = \"slip\")".into(),
            });
        }
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
        let parts = names.iter().zip(kinds).map(|(n, k)| BoundaryPart::new(n.clone(), k.unwrap_or(PartKind::Fixed))).collect();
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
fn shape_of<const D: usize>(g: &GroupSpec) -> Result<Option<Arc<dyn ClosestPoint<D>>>, String> {
    match (&g.shape, &g.level_set) {
        (Some(_), Some(_)) => Err("give `shape` or `level_set`, not both".into()),
        (None, None) => Ok(None),
        (None, Some(text)) => {
            let e = Expr::parse(text, &EXPR_VARS).map_err(|e| format!("field `level_set`: {e}"))?;
            Ok(Some(Arc::new(LevelSet::new(e)?)))
        }
        (Some(v), None) => shape_from_toml::<D>(v.get_ref()).map(Some),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
