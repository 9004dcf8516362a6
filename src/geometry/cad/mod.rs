//! CAD geometry: the curves and surfaces of a user's STEP, IGES, BREP,
//! XAO or `.geo` model, read by Gmsh's library ([`gmsh`], opened at run
//! time) and answered through the same [`ClosestPoint`] as the analytic
//! shapes, so Algorithm 2's sliding, the settling and the boundary
//! figures work on them unchanged.
//!
//! A [`CadModel`] is one file read into a Gmsh model of its own; a
//! [`CadShape`] is one of its entities: a curve (in 2D, a boundary of the
//! plane; in 3D, where two surfaces meet) or a surface. Every call goes
//! through the session's lock: Gmsh is not thread safe.
//!
//! Projections are Gmsh's `gmshModelGetClosestPoint`, 15 µs a call on a
//! cylinder and 70 µs on a B-spline face, most of it the call itself
//! (its parametrisation, `GetValue` with `GetDerivative`, costs 17 µs a
//! call too, so a Newton iteration of our own saves nothing). Algorithm
//! 2 asks for the same points again (a node's tangent stencil at the
//! start of a step, and its first Gauss–Newton iterate): each shape
//! remembers its answers, exactly, up to [`MEMO_SIZE`] points.
//!
//! Gmsh's projection of a point at the edge of an entity's parameter
//! range (a curve's end point) is only about 1e-8 of the model's size
//! off (measured on a B-spline airfoil's leading- and trailing-edge
//! points: 1.04e-8, 1.02e-8, both answered with parameter 0): there a
//! curve's end points are tried, and the foot is refined by Gauss–Newton
//! steps with the parameters clamped to the range, kept where they come
//! closer.
//!
//! A query that Gmsh fails cannot return an error through the trait: the
//! shape answers with the point itself and the model keeps the first such
//! failure ([`CadModel::failure`]), which the caller checks before it
//! writes anything.

mod gmsh;

use super::ClosestPoint;
use crate::numeric::{cross3, dot, norm, sub, unit};
use std::collections::HashMap;
use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

pub use gmsh::OLDEST;

/// How many answers a shape remembers before it forgets them all.
pub const MEMO_SIZE: usize = 1 << 20;

/// The files Gmsh reads as models, by extension.
pub const MODEL_EXTENSIONS: [&str; 8] = ["step", "stp", "iges", "igs", "brep", "xao", "geo", "geo_unrolled"];

/// Why a CAD model cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CadError {
    /// Gmsh's library is not on this machine (or not where it was named).
    #[error("{}", absent_message(*.named, .tried))]
    Absent {
        /// Whether `DEFORMESH_GMSH_LIB` (or the caller) named the place.
        named: bool,
        /// Each place tried, with the loader's reason.
        tried: Vec<String>,
    },
    /// A library was found but is not a usable Gmsh.
    #[error("{why}")]
    Library {
        /// What is wrong and what to do.
        why: String,
    },
    /// A Gmsh call failed.
    #[error("Gmsh's {call} failed: {message}")]
    Gmsh {
        /// The C function or option.
        call: String,
        /// Gmsh's last error.
        message: String,
    },
    /// The model file is not one Gmsh reads as a model.
    #[error("`{}`: a CAD model must be a .step/.stp, .iges/.igs, .brep, .xao or .geo file", .file.display())]
    Extension {
        /// The file.
        file: PathBuf,
    },
}

fn absent_message(named: bool, tried: &[String]) -> String {
    let head = if named {
        "`--cad` needs Gmsh's library, and DEFORMESH_GMSH_LIB names none that loads"
    } else {
        "`--cad` needs Gmsh's library (libgmsh), and none was found"
    };
    format!(
        "{head} (tried: {}). Install it with `pip install gmsh` (into the Python on PATH, or the active virtual environment), or your distribution's package (Gmsh {}.{} or later), or set DEFORMESH_GMSH_LIB to the library file (e.g. .venv/lib/libgmsh.so.4.15)",
        tried.join("; "),
        OLDEST.0,
        OLDEST.1
    )
}

/// A CAD file read by Gmsh into a model of its own.
#[derive(Debug)]
pub struct CadModel {
    name: CString,
    /// The file.
    pub file: PathBuf,
    /// The Gmsh library that read it.
    pub library: PathBuf,
    /// Its version.
    pub version: String,
    failure: Mutex<Option<CadError>>,
}

impl CadModel {
    /// Reads `file` with Gmsh, loading the library (from `library`, else
    /// the search of [`gmsh`]) on first use.
    pub fn open(file: &Path, library: Option<&Path>) -> Result<Arc<CadModel>, CadError> {
        let ext = file.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
        if !MODEL_EXTENSIONS.contains(&ext.as_str()) {
            return Err(CadError::Extension { file: file.to_path_buf() });
        }
        let mut guard = gmsh::session(library)?;
        let s = guard.as_mut().expect("session loaded");
        let name = s.open(file)?;
        Ok(Arc::new(CadModel { name, file: file.to_path_buf(), library: s.path.clone(), version: s.version.clone(), failure: Mutex::new(None) }))
    }

    /// Runs `f` on the session with this model current.
    fn with<R>(&self, f: impl FnOnce(&gmsh::Session) -> Result<R, CadError>) -> Result<R, CadError> {
        let mut guard = gmsh::session(None)?;
        let s = guard.as_mut().expect("session loaded");
        s.select(&self.name)?;
        f(s)
    }

    /// The tags of the model's entities of dimension `dim`.
    pub fn entities(&self, dim: usize) -> Result<Vec<i32>, CadError> {
        self.with(|s| Ok(s.entities(dim as i32)?.into_iter().map(|e| e.1).collect()))
    }

    /// The type Gmsh gives entity (dim, tag): "Plane", "Line", "Circle",
    /// "BSpline surface", …
    pub fn entity_type(&self, dim: usize, tag: i32) -> Result<String, CadError> {
        self.with(|s| s.entity_type(dim as i32, tag))
    }

    /// The tags of the entities of dimension `dim − 1` bounding (dim, tag).
    pub fn boundary(&self, dim: usize, tag: i32) -> Result<Vec<i32>, CadError> {
        self.with(|s| s.boundary(dim as i32, tag))
    }

    /// The coordinates of point entity `tag`.
    pub fn point(&self, tag: i32) -> Result<[f64; 3], CadError> {
        let v = self.with(|s| s.value(0, tag, &[]))?;
        Ok([v.first().copied().unwrap_or(f64::NAN), v.get(1).copied().unwrap_or(f64::NAN), v.get(2).copied().unwrap_or(f64::NAN)])
    }

    /// Entity (dim, tag) as a shape: dim 1 a curve, 2 a surface.
    pub fn shape(self: &Arc<Self>, dim: usize, tag: i32) -> CadShape {
        CadShape { model: self.clone(), dim: dim as i32, tag, memo: Arc::new(Mutex::new((HashMap::new(), None))) }
    }

    /// The first query Gmsh failed, if any: its answers are not on the
    /// model, and nothing computed with them may be written.
    pub fn failure(&self) -> Option<CadError> {
        self.failure.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    fn record(&self, e: CadError) {
        self.failure.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(e);
    }
}

/// One entity of a [`CadModel`]: a curve or a surface.
#[derive(Clone, Debug)]
pub struct CadShape {
    model: Arc<CadModel>,
    dim: i32,
    tag: i32,
    /// Answers given: query (bits) → foot point and normal; and the
    /// parameter range, once asked.
    memo: Arc<Mutex<(Memo, Option<[[f64; 2]; 2]>)>>,
}

type Memo = HashMap<[u64; 4], ([f64; 3], [f64; 3])>;

impl CadShape {
    /// Its entity tag.
    pub fn tag(&self) -> i32 {
        self.tag
    }

    /// Its dimension (1 or 2).
    pub fn dim(&self) -> usize {
        self.dim as usize
    }

    /// The closest point to `p` and, there, a unit normal: the surface's,
    /// or for a curve the direction from the curve to `p` (in the plane:
    /// the tangent turned clockwise).
    fn project(&self, p: [f64; 3], planar: bool) -> ([f64; 3], [f64; 3]) {
        let key = [p[0].to_bits(), p[1].to_bits(), p[2].to_bits(), planar as u64];
        let mut guard = self.memo.lock().unwrap_or_else(|e| e.into_inner());
        let (memo, range) = &mut *guard;
        if let Some(&r) = memo.get(&key) {
            return r;
        }
        let found = self.model.with(|s| {
            let (x, uv) = s.closest(self.dim, self.tag, &p)?;
            let k = self.dim as usize;
            if x.len() < 3 || uv.len() < k {
                return Err(CadError::Gmsh { call: "gmshModelGetClosestPoint".into(), message: format!("no point of entity ({}, {}) found", self.dim, self.tag) });
            }
            if range.is_none() {
                let (lo, hi) = s.parameter_bounds(self.dim, self.tag)?;
                let two = |v: &[f64]| [v.first().copied().unwrap_or(0.0), v.get(1).copied().unwrap_or(0.0)];
                *range = Some([two(&lo), two(&hi)]);
            }
            let uv = [uv[0], if k == 2 { uv[1] } else { 0.0 }];
            let (q, uv) = self.at_range_edge(s, p, ([x[0], x[1], x[2]], uv), range.expect("set"))?;
            let n = if self.dim == 2 {
                let n = s.normal(self.tag, &uv[..k])?;
                [n[0], n[1], n[2]]
            } else {
                let t = s.derivative(1, self.tag, &uv[..k])?;
                curve_normal([t[0], t[1], t[2]], sub(p, q), planar)
            };
            Ok((q, n))
        });
        match found {
            Ok(r) => {
                if memo.len() >= MEMO_SIZE {
                    memo.clear();
                }
                memo.insert(key, r);
                r
            }
            Err(e) => {
                self.model.record(e);
                (p, [0.0, 0.0, 1.0])
            }
        }
    }
}

impl CadShape {
    /// Gmsh's foot `found` (point, parameters) of `p`, refined where its
    /// parameters are at the edge of `range` (see the module docs).
    fn at_range_edge(&self, s: &gmsh::Session, p: [f64; 3], found: ([f64; 3], [f64; 2]), range: [[f64; 2]; 2]) -> Result<([f64; 3], [f64; 2]), CadError> {
        let k = self.dim as usize;
        let [lo, hi] = range;
        let edge = (0..k).any(|j| {
            let w = 1e-6 * (hi[j] - lo[j]).abs();
            found.1[j] - lo[j] <= w || hi[j] - found.1[j] <= w
        });
        if !edge {
            return Ok(found);
        }
        let (mut q, mut uv) = found;
        if k == 1 {
            // Gmsh answers a curve's end point with parameter 0 whichever
            // end it is: try both ends
            for end in [lo[0], hi[0]] {
                let x = s.value(1, self.tag, &[end])?;
                let e = [x[0], x[1], x[2]];
                if norm(sub(p, e)) < norm(sub(p, q)) {
                    (q, uv) = (e, [end, 0.0]);
                }
            }
        }
        for _ in 0..4 {
            let d = s.derivative(self.dim, self.tag, &uv[..k])?;
            let t: Vec<[f64; 3]> = (0..k).map(|j| [d[3 * j], d[3 * j + 1], d[3 * j + 2]]).collect();
            let r = sub(p, q);
            // a diagonal step per parameter: clamped at the edge, the
            // other one alone moves
            let mut next = uv;
            for j in 0..k {
                let m = dot(t[j], t[j]);
                if m > 0.0 {
                    next[j] = (uv[j] + dot(t[j], r) / m).clamp(lo[j].min(hi[j]), hi[j].max(lo[j]));
                }
            }
            let x = s.value(self.dim, self.tag, &next[..k])?;
            let nq = [x[0], x[1], x[2]];
            if !(norm(sub(p, nq)) < norm(r)) {
                break;
            }
            (q, uv) = (nq, next);
        }
        Ok((q, uv))
    }
}

/// A unit normal of a curve with tangent `t` towards the offset `d` of a
/// point from it: in the plane (z = 0) `t` turned clockwise; in space `d`
/// without its part along `t`, or any unit vector across `t` where `d`
/// is along it.
fn curve_normal(t: [f64; 3], d: [f64; 3], planar: bool) -> [f64; 3] {
    if planar {
        return unit([t[1], -t[0], 0.0]);
    }
    let tu = unit(t);
    let across = sub(d, tu.map(|c| c * dot(d, tu)));
    if norm(across) > 1e-14 * (1.0 + norm(d)) {
        return unit(across);
    }
    let axis = if tu[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    unit(cross3(tu, axis))
}

fn lift<const D: usize>(p: [f64; D]) -> [f64; 3] {
    std::array::from_fn(|i| if i < D { p[i] } else { 0.0 })
}

fn drop_to<const D: usize>(p: [f64; 3]) -> [f64; D] {
    std::array::from_fn(|i| p[i])
}

impl<const D: usize> ClosestPoint<D> for CadShape {
    fn closest_point(&self, p: [f64; D]) -> [f64; D] {
        drop_to(self.project(lift(p), D == 2).0)
    }

    fn normal(&self, p: [f64; D]) -> [f64; D] {
        drop_to(self.project(lift(p), D == 2).1)
    }

    /// By Newton's method on the signed distance along the ray (CAD parts
    /// are bound by closest points; this answers a ray asked of one).
    fn ray_hit(&self, origin: [f64; D], dir: [f64; D]) -> Option<[f64; D]> {
        let (o, d) = (lift(origin), lift(dir));
        if norm(d) == 0.0 {
            return None;
        }
        let mut s = 0.0;
        for _ in 0..50 {
            let x: [f64; 3] = std::array::from_fn(|i| o[i] + s * d[i]);
            let (q, n) = self.project(x, D == 2);
            let dn = dot(d, n);
            if dn.abs() < 1e-12 * norm(d) {
                return None;
            }
            let step = dot(sub(q, x), n) / dn;
            s += step;
            if step.abs() * norm(d) <= 1e-13 * (1.0 + norm(x)) {
                let hit: [f64; 3] = std::array::from_fn(|i| o[i] + s * d[i]);
                let on = norm(sub(self.project(hit, D == 2).0, hit)) <= 1e-10 * (1.0 + norm(hit));
                return (s * norm(d) > 1e-12 * (1.0 + norm(o)) && on).then(|| drop_to(self.project(hit, D == 2).0));
            }
        }
        None
    }
}
