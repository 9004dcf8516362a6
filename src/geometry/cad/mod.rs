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
//! A foot is found by Newton's method on |S(u, v) − p|² in the entity's
//! parameters (`CadShape::newton`: Gmsh's `GetValue`, `GetDerivative`,
//! `GetSecondDerivative`, a few µs each), started from the parameters of
//! a foot found for a query in the same seed cell (`SEED_CELL`). Gmsh's
//! `gmshModelGetClosestPoint` (11 µs a call on a B-spline curve, 70 µs on
//! a B-spline face) is the fallback where there is no seed or Newton
//! fails, and its answer is polished by the same Newton: on its own it is
//! only about 1e-9 of the model's size close, on curves Gmsh 4.15 answers
//! parameter 0 for most feet (the parameter is asked of
//! `GetParametrization`), and at a curve's end it may answer the other
//! end (both ends are tried). Algorithm 2 asks for the same points again
//! (a node's tangent stencil, its first Gauss–Newton iterate): each shape
//! remembers its answers, exactly, up to [`MEMO_SIZE`] points.
//!
//! A query that Gmsh fails cannot return an error through the trait: the
//! shape answers with the point itself and the model keeps the first such
//! failure ([`CadModel::failure`]), which the caller checks before it
//! writes anything.

pub mod classify;
mod gmsh;
pub mod live;

use super::ClosestPoint;
use crate::numeric::{cross3, dist2, dot, mix, sub, unit};
use std::collections::HashMap;
use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

pub use gmsh::OLDEST;

/// How many answers a shape remembers before it forgets them all. The
/// repeated questions come soon after the first (a tangent stencil, a
/// Gauss–Newton iterate, a fitted place asked again by its snap): at
/// 1 << 20 it could hold a million answers the fits ask once, 96 bytes
/// each (the OCC torus of 5,082 tetrahedra at p = 3: peak 367 MB, 198 MB
/// at 1 << 16 with the same figures written; FastCurving's 68 MB).
pub const MEMO_SIZE: usize = 1 << 16;

/// How many seed cells a shape remembers before it forgets them; apart
/// from the memo, since a forgotten seed costs a query Gmsh's own closest
/// point (70 µs on a B-spline face) instead of a few Newton steps.
pub const SEEDS_SIZE: usize = 1 << 18;

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
    /// A scale asked for a model Gmsh does not scale on reading.
    #[error("`{}`: a scale (--cad-scale) applies to STEP, IGES and BREP models only: write the model as STEP or BREP (gmsh.write(\"model.step\"))", .file.display())]
    Unscalable {
        /// The file.
        file: PathBuf,
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

/// A link (or a copy) of a model file under a name whose extension is in
/// lower case, in a folder of its own under the temporary folder; removed
/// when dropped.
struct LowerCaseLink {
    path: PathBuf,
}

impl LowerCaseLink {
    fn new(file: &Path, ext: &str) -> Result<LowerCaseLink, CadError> {
        static COUNT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("deformesh-cad-{}-{n}", std::process::id()));
        let stem = file.file_stem().map_or("model".into(), |s| s.to_string_lossy().into_owned());
        let path = dir.join(format!("{stem}.{ext}"));
        let fail = |e: std::io::Error| CadError::Gmsh { call: "reading the model".into(), message: format!("cannot link `{}` under a lower-case extension in `{}`: {e}", file.display(), dir.display()) };
        std::fs::create_dir_all(&dir).map_err(fail)?;
        let target = file.canonicalize().map_err(fail)?;
        #[cfg(unix)]
        let made = std::os::unix::fs::symlink(&target, &path).or_else(|_| std::fs::copy(&target, &path).map(|_| ()));
        #[cfg(not(unix))]
        let made = std::fs::copy(&target, &path).map(|_| ());
        if let Err(e) = made {
            let _ = std::fs::remove_dir_all(&dir);
            return Err(fail(e));
        }
        Ok(LowerCaseLink { path })
    }
}

impl Drop for LowerCaseLink {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
        if let Some(dir) = self.path.parent() {
            let _ = std::fs::remove_dir(dir);
        }
    }
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
    /// The factor its coordinates were multiplied by on reading.
    pub scale: f64,
    failure: Mutex<Option<CadError>>,
    /// The current model of a Gmsh the process had initialised ([`live`]):
    /// never switched, whatever its name.
    live: bool,
}

impl CadModel {
    /// Reads `file` with Gmsh, loading the library (from `library`, else
    /// the search of [`gmsh`]) on first use.
    pub fn open(file: &Path, library: Option<&Path>) -> Result<Arc<CadModel>, CadError> {
        CadModel::open_scaled(file, library, 1.0)
    }

    /// [`CadModel::open`], the model's coordinates times `scale` (a model
    /// in other units than its mesh's): for STEP, IGES and BREP files,
    /// which Gmsh scales as OpenCASCADE reads them.
    pub fn open_scaled(file: &Path, library: Option<&Path>, scale: f64) -> Result<Arc<CadModel>, CadError> {
        let ext = file.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
        if !MODEL_EXTENSIONS.contains(&ext.as_str()) {
            return Err(CadError::Extension { file: file.to_path_buf() });
        }
        // Gmsh scales what OpenCASCADE imports, not an .xao or a script
        // (measured: an .xao read at scale 1000 keeps its size)
        if scale != 1.0 && !matches!(ext.as_str(), "step" | "stp" | "iges" | "igs" | "brep") {
            return Err(CadError::Unscalable { file: file.to_path_buf() });
        }
        let mut guard = gmsh::session(library)?;
        let s = guard.as_mut().expect("session loaded");
        // Gmsh tells the format by the extension as written, lower or upper
        // case alone (`.step`, `.STEP`), and reads any other as a .geo
        // script: a `.Stp` is read through a link of a lower-case name
        let written = file.extension().and_then(|e| e.to_str()).unwrap_or_default();
        let link = (written != ext && !ext.starts_with("geo")).then(|| LowerCaseLink::new(file, &ext)).transpose()?;
        let name = s.open(link.as_ref().map_or(file, |l| l.path.as_path()), scale)?;
        drop(link);
        Ok(Arc::new(CadModel { name, file: file.to_path_buf(), library: s.path.clone(), version: s.version.clone(), scale, failure: Mutex::new(None), live: false }))
    }

    /// Runs `f` on the session with this model current.
    fn with<R>(&self, f: impl FnOnce(&gmsh::Session) -> Result<R, CadError>) -> Result<R, CadError> {
        let mut guard = gmsh::session(None)?;
        let s = guard.as_mut().expect("session loaded");
        if !self.live {
            s.select(&self.name)?;
        }
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

    /// The bounding box `[min, max]` of entity (dim, tag); of the whole
    /// model for (-1, -1).
    pub fn bounding_box(&self, dim: i32, tag: i32) -> Result<[[f64; 3]; 2], CadError> {
        self.with(|s| s.bounding_box(dim, tag))
    }

    /// The closest points of entity (dim, tag) to `points`, in one call
    /// (an untrimmed surface's: see [`CadModel::count_inside`]).
    pub fn closest_points(&self, dim: usize, tag: i32, points: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, CadError> {
        let flat: Vec<f64> = points.iter().flatten().copied().collect();
        let (x, _) = self.with(|s| s.closest(dim as i32, tag, &flat))?;
        Ok(x.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// How many of `points` lie on entity (dim, tag), a face's trimming
    /// (its holes, its outline) heeded.
    pub fn count_inside(&self, dim: usize, tag: i32, points: &[[f64; 3]]) -> Result<usize, CadError> {
        let flat: Vec<f64> = points.iter().flatten().copied().collect();
        self.with(|s| s.count_inside(dim as i32, tag, &flat))
    }

    /// `n` points of curve `tag`, evenly spaced in its parameter.
    pub fn curve_points(&self, tag: i32, n: usize) -> Result<Vec<[f64; 3]>, CadError> {
        self.with(|s| {
            let (lo, hi) = s.parameter_bounds(1, tag)?;
            let (a, b) = (lo.first().copied().unwrap_or(0.0), hi.first().copied().unwrap_or(1.0));
            let t: Vec<f64> = (0..n).map(|k| a + (b - a) * k as f64 / (n.max(2) - 1) as f64).collect();
            Ok(s.value(1, tag, &t)?.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        })
    }

    /// Entity (dim, tag) as a shape: dim 1 a curve, 2 a surface.
    pub fn shape(self: &Arc<Self>, dim: usize, tag: i32) -> CadShape {
        CadShape { model: self.clone(), dim: dim as i32, tag, known: Arc::new(Mutex::new(Known::default())) }
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
    /// What it has learnt of itself (see [`Known`]).
    known: Arc<Mutex<Known>>,
}

/// A shape's answers so far: each query's answer, exactly, up to
/// [`MEMO_SIZE`]; the parameters of a foot per seed cell, from which a
/// query nearby starts Newton's method; the parameter range; and the sign
/// that turns ∂u × ∂v into Gmsh's normal of a surface.
#[derive(Debug, Default)]
struct Known {
    memo: HashMap<[u64; 4], Answer, Mixed>,
    seeds: HashMap<[i64; 3], [f64; 2], Mixed>,
    /// Range, seed cell size, normal sign: found at the first query.
    frame: Option<Frame>,
}

#[derive(Clone, Copy, Debug)]
struct Frame {
    range: [[f64; 2]; 2],
    cell: f64,
    sign: f64,
    /// Per parameter: the shape closes on itself there (a circle, a
    /// cylinder's seam), so a foot on the seam has two parameters.
    closed: [bool; 2],
}

/// A query's answer: the foot, the unit normal there, the foot's
/// parameters.
type Answer = ([f64; 3], [f64; 3], [f64; 2]);

/// |a|. Not [`crate::numeric::norm`]'s `hypot`: its care for overflow
/// (components beyond 1e154, no model's) cost 6 % of a CAD run, in the
/// projections' Newton steps.
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// A seed cell's side, as a fraction of the entity's bounding box: a query
/// starts from a foot found for a point this close (the feet of such
/// points are close unless the point is near the shape's medial axis,
/// which the nodes and samples of a mesh on the shape are not).
const SEED_CELL: f64 = 1e-3;

/// The 26 cells around a seed cell, nearest first (sharing a side, then
/// an edge, then a corner).
const NEIGHBOURS: [[i64; 3]; 26] = {
    let mut out = [[0; 3]; 26];
    let mut n = 0;
    let mut shared = 1;
    while shared <= 3 {
        let mut k = 0;
        while k < 27 {
            let o = [k as i64 % 3 - 1, (k as i64 / 3) % 3 - 1, k as i64 / 9 - 1];
            if o[0].abs() + o[1].abs() + o[2].abs() == shared {
                out[n] = o;
                n += 1;
            }
            k += 1;
        }
        shared += 1;
    }
    out
};

/// The seed of `cell`, else of the nearest cell around it holding one.
fn seed_near(seeds: &HashMap<[i64; 3], [f64; 2], Mixed>, cell: [i64; 3]) -> Option<[f64; 2]> {
    seeds.get(&cell).or_else(|| NEIGHBOURS.iter().find_map(|o| seeds.get(&std::array::from_fn(|i| cell[i] + o[i])))).copied()
}

/// A hasher for the memo's and the seeds' keys (a few words of bits):
/// each word multiplied in, the sum mixed at the end (the standard
/// SipHash cost as much as a Newton step's evaluation).
#[derive(Clone, Copy, Debug, Default)]
struct Mixed(u64);

impl std::hash::Hasher for Mixed {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn finish(&self) -> u64 {
        let mut x = self.0;
        x ^= x >> 33;
        x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
        x ^ (x >> 33)
    }
}

impl std::hash::BuildHasher for Mixed {
    type Hasher = Mixed;

    fn build_hasher(&self) -> Mixed {
        Mixed(0)
    }
}

impl Known {
    /// Remembers the answer `r` to the query `key`; at [`MEMO_SIZE`]
    /// answers it first forgets them all.
    fn remember(&mut self, key: [u64; 4], r: Answer) {
        if self.memo.len() >= MEMO_SIZE {
            self.memo.clear();
        }
        self.memo.insert(key, r);
    }

    /// Remembers the parameters `uv` of a foot found in seed cell `cell`;
    /// at [`SEEDS_SIZE`] cells it first forgets them all.
    fn seed(&mut self, cell: [i64; 3], uv: [f64; 2]) {
        if self.seeds.len() >= SEEDS_SIZE {
            self.seeds.clear();
        }
        self.seeds.insert(cell, uv);
    }

    /// The shape's frame, found at its first query.
    fn frame_of(&mut self, shape: &CadShape, s: &gmsh::Session) -> Result<Frame, CadError> {
        match self.frame {
            Some(f) => Ok(f),
            None => Ok(*self.frame.insert(shape.frame(s)?)),
        }
    }
}

/// The memo's key of a query: the point's bits, and whether in the plane.
fn memo_key(p: &[f64; 3], planar: bool) -> [u64; 4] {
    [p[0].to_bits(), p[1].to_bits(), p[2].to_bits(), planar as u64]
}

/// The foot of a query, its parameters and its first derivatives.
struct Foot {
    x: [f64; 3],
    uv: [f64; 2],
    d: [[f64; 3]; 2],
}

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
        let key = memo_key(&p, planar);
        let mut known = self.known.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(&r) = known.memo.get(&key) {
            return (r.0, r.1);
        }
        match self.model.with(|s| self.solve(s, &mut known, p, planar)) {
            Ok(r) => {
                known.remember(key, r);
                (r.0, r.1)
            }
            Err(e) => {
                self.model.record(e);
                (p, [0.0, 0.0, 1.0])
            }
        }
    }

    /// [`Self::project`] of each of `ps`, in order, with the same answers
    /// up to round-off: the memo asked first, then the rest under one hold
    /// of the session, Newton's method run on all the seeded points at once
    /// (each of Gmsh's evaluations takes every point's parameters in one
    /// call: one lock, one entity look-up and one array per step, not per
    /// point and step).
    fn project_all(&self, ps: &[[f64; 3]], planar: bool) -> Vec<Answer> {
        let mut known = self.known.lock().unwrap_or_else(|e| e.into_inner());
        let mut out: Vec<Option<Answer>> = ps.iter().map(|p| known.memo.get(&memo_key(p, planar)).copied()).collect();
        let fresh: Vec<usize> = (0..ps.len()).filter(|&i| out[i].is_none()).collect();
        if !fresh.is_empty() {
            if let Err(e) = self.model.with(|s| self.solve_all(s, &mut known, ps, planar, &mut out)) {
                self.model.record(e);
            }
            for &i in &fresh {
                if let Some(r) = out[i] {
                    known.remember(memo_key(&ps[i], planar), r);
                }
            }
        }
        ps.iter().zip(out).map(|(&p, r)| r.unwrap_or((p, [0.0, 0.0, 1.0], [f64::NAN; 2]))).collect()
    }

    /// [`ClosestPoint::largest_sample_distance`]: each sample's foot by
    /// Gauss–Newton from the same mix of its element's nodes' foot
    /// parameters (the nodes lie on the shape, their feet are in the memo),
    /// every sample's evaluations of a step in one call, to 1e-9 of the
    /// element's size (the distance's error is that squared times the
    /// curvature); without the memo, the seeds or the settling, since a
    /// sample is asked once (on the 5,082-tet torus those cost more than
    /// the evaluations: a quarter of the run). Samples whose steps fail
    /// and elements whose nodes straddle a closed shape's seam are asked
    /// of [`Self::project_all`]. A step that is not converged leaves a
    /// point of the shape, so a distance is never under the true one.
    fn largest_sample_distance(&self, nodes: &[[f64; 3]], weights: &[Vec<f64>], planar: bool) -> f64 {
        let ps: Vec<[f64; 3]> = weights.iter().map(|w| mix(w, nodes)).collect();
        let feet: Vec<[f64; 2]> = self.project_all(nodes, planar).into_iter().map(|a| a.2).collect();
        let k = self.dim as usize;
        let frame = self.known.lock().unwrap_or_else(|e| e.into_inner()).frame;
        // a seam between the nodes: their parameters' mix is elsewhere
        let one_side = |f: &Frame| {
            (0..k).all(|l| {
                let (lo, hi) = bounds(f.range, l);
                let (a, b) = feet.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), uv| (a.min(uv[l]), b.max(uv[l])));
                a.is_finite() && b.is_finite() && (!f.closed[l] || b - a < 0.5 * (hi - lo))
            })
        };
        let mut found = vec![None; ps.len()];
        if let Some(frame) = frame.filter(one_side) {
            let size = nodes.iter().map(|&a| dist2(a, nodes[0])).fold(0.0, f64::max).sqrt();
            let uv = weights.iter().map(|w| mix(w, &feet)).collect();
            match self.model.with(|s| self.descend(s, &ps, uv, &frame, 1e-9 * size)) {
                Ok(d) => found = d,
                Err(e) => self.model.record(e),
            }
        }
        let rest: Vec<[f64; 3]> = ps.iter().zip(&found).filter(|(_, d)| d.is_none()).map(|(&p, _)| p).collect();
        let asked = rest.iter().zip(self.project_all(&rest, planar)).map(|(&p, a)| norm(sub(p, a.0)));
        found.into_iter().flatten().chain(asked).fold(0.0, f64::max)
    }

    /// The distance of each of `ps` to the shape by Gauss–Newton from the
    /// parameters `uv` (the Hessian without the second derivatives: the
    /// points are close to the shape, where the term they add is the
    /// distance times the curvature), ended when a step moves the foot by
    /// at most `tol`; None where it does not end in 8 steps or a step
    /// leaves the range.
    fn descend(&self, s: &gmsh::Session, ps: &[[f64; 3]], mut uv: Vec<[f64; 2]>, frame: &Frame, tol: f64) -> Result<Vec<Option<f64>>, CadError> {
        let k = self.dim as usize;
        let flat = |at: &[usize], uv: &[[f64; 2]]| -> Vec<f64> { at.iter().flat_map(|&i| uv[i][..k].to_vec()).collect() };
        let mut out = vec![None; ps.len()];
        let mut active: Vec<usize> = (0..ps.len()).collect();
        for _ in 0..8 {
            if active.is_empty() {
                break;
            }
            let at = flat(&active, &uv);
            let v = s.value(self.dim, self.tag, &at)?;
            self.enough("gmshModelGetValue", &v, 3, active.len())?;
            let ds = s.derivative(self.dim, self.tag, &at)?;
            self.enough("gmshModelGetDerivative", &ds, 3 * k, active.len())?;
            let mut next = Vec::with_capacity(active.len());
            for (j, &i) in active.iter().enumerate() {
                let r = sub([v[3 * j], v[3 * j + 1], v[3 * j + 2]], ps[i]);
                let d = tangents(&ds[3 * k * j..3 * k * (j + 1)], k);
                let Some(step) = newton_step(d, &[0.0; 9], r, k) else { continue };
                if (0..k).map(|l| step[l].abs() * norm(d[l])).fold(0.0, f64::max) <= tol {
                    out[i] = Some(norm(r));
                    continue;
                }
                let to = step_in_range(uv[i], step, frame.range, k);
                if (0..k).all(|l| to[l] == uv[i][l] + step[l]) {
                    uv[i] = to;
                    next.push(i);
                }
            }
            active = next;
        }
        Ok(out)
    }

    /// The derivative of the foot map at each of `ps` along `dirs[i]`
    /// (the closest point's speed as the point moves by `dirs[i]`): from
    /// the parameters of the foot, J H⁻¹ Jᵀ dir, where J holds the
    /// tangents and H is Newton's Hessian of |S − p|² there. None where it
    /// does not hold: the foot on the side of the parameter range (a
    /// bound, or a closed shape's seam), the Hessian not positive, a
    /// failed query.
    fn foot_speeds(&self, ps: &[[f64; 3]], dirs: &[[f64; 3]], planar: bool) -> Vec<Option<[f64; 3]>> {
        let answers = self.project_all(ps, planar);
        let k = self.dim as usize;
        let range = {
            let known = self.known.lock().unwrap_or_else(|e| e.into_inner());
            known.frame.map(|f| f.range)
        };
        let Some(range) = range else { return vec![None; ps.len()] };
        // inside the range by a margin: at its side the foot may be held
        // there (Newton's `edge`) or cross a seam, where J H⁻¹ Jᵀ is not
        // its derivative
        let inside = |uv: [f64; 2]| {
            (0..k).all(|l| {
                let (lo, hi) = bounds(range, l);
                let margin = 1e-6 * (hi - lo);
                uv[l] > lo + margin && uv[l] < hi - margin
            })
        };
        let at: Vec<usize> = (0..ps.len()).filter(|&i| answers[i].2.iter().all(|v| v.is_finite()) && inside(answers[i].2)).collect();
        let mut out = vec![None; ps.len()];
        if at.is_empty() {
            return out;
        }
        let uv: Vec<f64> = at.iter().flat_map(|&i| answers[i].2[..k].to_vec()).collect();
        let seconds = if k == 1 { 1 } else { 3 };
        let evaluated = self.model.with(|s| Ok((s.derivative(self.dim, self.tag, &uv)?, s.second_derivative(self.dim, self.tag, &uv)?)));
        let (ds, dds) = match evaluated {
            Ok(v) if v.0.len() >= 3 * k * at.len() && v.1.len() >= 3 * seconds * at.len() => v,
            Ok(_) => return out,
            Err(e) => {
                self.model.record(e);
                return out;
            }
        };
        for (j, &i) in at.iter().enumerate() {
            let d = tangents(&ds[3 * k * j..3 * k * (j + 1)], k);
            let dd = &dds[3 * seconds * j..3 * seconds * (j + 1)];
            let w = dirs[i];
            out[i] = hessian(d, dd, sub(answers[i].0, ps[i]), k).map(|[huu, hvv, huv, det]| {
                if k == 1 {
                    return d[0].map(|c| c * dot(d[0], w) / huu);
                }
                let (gu, gv) = (dot(d[0], w), dot(d[1], w));
                let (a, b) = ((hvv * gu - huv * gv) / det, (huu * gv - huv * gu) / det);
                std::array::from_fn(|c| a * d[0][c] + b * d[1][c])
            });
        }
        out
    }

    /// The feet of the points of `ps` not yet in `out`, and the normals
    /// there, into `out`: a point with no seed around it as
    /// [`Self::solve`] does (it leaves one), then Newton's method on all
    /// the seeded ones at once; Gmsh's projection where that fails.
    fn solve_all(&self, s: &gmsh::Session, known: &mut Known, ps: &[[f64; 3]], planar: bool, out: &mut [Option<Answer>]) -> Result<(), CadError> {
        let frame = known.frame_of(self, s)?;
        let cell_of = |p: &[f64; 3]| p.map(|c| (c / frame.cell).floor() as i64);
        let mut seeded: Vec<(usize, [f64; 2])> = Vec::new();
        // a point with no seed around it is projected by Gmsh (which
        // leaves a seed). Not from the nearest point of the batch already
        // answered, as until 7 December: a batch holds the points of many
        // lines, and a neighbour 10 cells away across a thin trailing edge
        // led Newton's method to the foot on the other side (the
        // three-element airfoil at p = 3: one element more not valid
        // after the snap, and no repair)
        for (i, p) in ps.iter().enumerate() {
            if out[i].is_some() {
                continue;
            }
            match seed_near(&known.seeds, cell_of(p)) {
                Some(uv) => seeded.push((i, uv)),
                None => out[i] = Some(self.solve(s, known, *p, planar)?),
            }
        }
        if seeded.is_empty() {
            return Ok(());
        }
        let points: Vec<[f64; 3]> = seeded.iter().map(|&(i, _)| ps[i]).collect();
        let feet = self.newton_all(s, &points, seeded.iter().map(|&(_, uv)| uv).collect(), &frame)?;
        for (&(i, _), foot) in seeded.iter().zip(feet) {
            let p = ps[i];
            let foot = match foot {
                Some(f) => f,
                None => self.gmsh_foot(s, p, &frame)?,
            };
            known.seed(cell_of(&p), foot.uv);
            let n = if self.dim == 2 { self.surface_normal(s, &foot, frame.sign)? } else { curve_normal(foot.d[0], sub(p, foot.x), planar) };
            out[i] = Some((foot.x, n, foot.uv));
        }
        Ok(())
    }

    /// [`Self::newton`] (with `edge` false) of each of `ps` from its
    /// parameters in `uv`, all the points' evaluations of a step in one
    /// call of each of Gmsh's functions; the same arithmetic per point
    /// but the end: a step sooner where the moves fall quadratically (the
    /// settling's step, which every foot here takes, is the last one;
    /// `newton`'s feet are not all settled, so it keeps its 1e-10).
    fn newton_all(&self, s: &gmsh::Session, ps: &[[f64; 3]], mut uv: Vec<[f64; 2]>, frame: &Frame) -> Result<Vec<Option<Foot>>, CadError> {
        let range = frame.range;
        let k = self.dim as usize;
        // Gmsh's second derivatives per point: x_tt, or x_uu, x_vv, x_uv
        let seconds = if k == 1 { 1 } else { 3 };
        let args = |at: &[usize], uv: &[[f64; 2]]| -> Vec<f64> { at.iter().flat_map(|&i| uv[i][..k].to_vec()).collect() };
        let short = |call: &str, v: &[f64], per: usize, n: usize| self.enough(call, v, per, n);
        let mut active: Vec<usize> = (0..ps.len()).collect();
        let v = s.value(self.dim, self.tag, &args(&active, &uv))?;
        short("gmshModelGetValue", &v, 3, active.len())?;
        let mut x: Vec<[f64; 3]> = (0..ps.len()).map(|j| [v[3 * j], v[3 * j + 1], v[3 * j + 2]]).collect();
        let mut converged: Vec<usize> = Vec::new();
        // each point's last move: where the moves fall quadratically the
        // next would be under round-off, and the settling's step is it
        // (none before the first: one move says nothing of the rate)
        let mut last = vec![0.0; ps.len()];
        for _ in 0..16 {
            if active.is_empty() {
                break;
            }
            let at = args(&active, &uv);
            let ds = s.derivative(self.dim, self.tag, &at)?;
            short("gmshModelGetDerivative", &ds, 3 * k, active.len())?;
            let dds = s.second_derivative(self.dim, self.tag, &at)?;
            short("gmshModelGetSecondDerivative", &dds, 3 * seconds, active.len())?;
            let mut moved = Vec::with_capacity(active.len());
            let mut stepped = Vec::with_capacity(active.len());
            for (j, &i) in active.iter().enumerate() {
                let d = tangents(&ds[3 * k * j..3 * k * (j + 1)], k);
                let dd = &dds[3 * seconds * j..3 * seconds * (j + 1)];
                let Some(step) = newton_step(d, dd, sub(x[i], ps[i]), k) else { continue };
                let next = step_in_range(uv[i], step, range, k);
                // across the range's side: Gmsh's projection finds the foot
                if (0..k).any(|l| next[l] != uv[i][l] + step[l]) {
                    continue;
                }
                moved.push((0..k).map(|l| (next[l] - uv[i][l]).abs() * norm(d[l])).fold(0.0, f64::max));
                uv[i] = next;
                stepped.push(i);
            }
            let v = s.value(self.dim, self.tag, &args(&stepped, &uv))?;
            short("gmshModelGetValue", &v, 3, stepped.len())?;
            active.clear();
            for (j, &i) in stepped.iter().enumerate() {
                x[i] = [v[3 * j], v[3 * j + 1], v[3 * j + 2]];
                let size = 1.0 + norm(ps[i]);
                // converged; or, where Newton's method converges
                // quadratically, the next move under 1e-12, which the
                // settling's step takes (it starts from the grid's point,
                // 5e-10 of the range away, anyway): a first move under
                // 1e-7 (a seed that close), or one under 1e-6 and a
                // thousandth of the last (the next is move³/last²); a
                // step of three Gmsh calls saved per projection
                let quadratic = if last[i] == 0.0 { moved[j] <= 1e-7 * size } else { moved[j] <= 1e-6 * size && moved[j] <= 1e-3 * last[i] };
                if moved[j] <= 1e-10 * size || quadratic {
                    converged.push(i);
                } else {
                    last[i] = moved[j];
                    active.push(i);
                }
            }
        }
        let mut out: Vec<Option<Foot>> = (0..ps.len()).map(|_| None).collect();
        if !converged.is_empty() {
            let points: Vec<[f64; 3]> = converged.iter().map(|&i| ps[i]).collect();
            let feet = self.settle(s, &points, &converged.iter().map(|&i| (x[i], uv[i])).collect::<Vec<_>>(), frame)?;
            for (&i, foot) in converged.iter().zip(feet) {
                out[i] = Some(foot);
            }
        }
        Ok(out)
    }

    /// The feet of `ps` from parameters `uv` that Newton's method has
    /// converged to, made a function of the point alone: the parameters
    /// put on a grid of 2⁻³⁰ of the range, then one more Newton step.
    /// Why: Newton's method from two seeds (a seed is the foot of whichever
    /// point of its cell was asked first, which depends on the order of the
    /// queries) ends a few ulps apart, and the fit's later steps carried
    /// that to 1.1e-11 of the model between two runs of the same file. The
    /// grid's half-step (5e-10 of the range) is squared by the step, far
    /// under round-off; only a foot within ulps of a grid line's midpoint
    /// can still differ. A foot on a closed shape's seam is given the
    /// range's low end ([`on_seam`]).
    fn settle(&self, s: &gmsh::Session, ps: &[[f64; 3]], converged: &[([f64; 3], [f64; 2])], frame: &Frame) -> Result<Vec<Foot>, CadError> {
        let range = frame.range;
        let k = self.dim as usize;
        let seconds = if k == 1 { 1 } else { 3 };
        let n = ps.len();
        let size = frame.cell / SEED_CELL;
        let flat = |uv: &[[f64; 2]]| -> Vec<f64> { uv.iter().flat_map(|u| u[..k].to_vec()).collect() };
        let uv: Vec<[f64; 2]> = converged.iter().map(|c| on_grid(c.1, range, k)).collect();
        let v = s.value(self.dim, self.tag, &flat(&uv))?;
        self.enough("gmshModelGetValue", &v, 3, n)?;
        let ds = s.derivative(self.dim, self.tag, &flat(&uv))?;
        self.enough("gmshModelGetDerivative", &ds, 3 * k, n)?;
        let dds = s.second_derivative(self.dim, self.tag, &flat(&uv))?;
        self.enough("gmshModelGetSecondDerivative", &dds, 3 * seconds, n)?;
        // the foot and tangents after the step from the grid's point by
        // Taylor's expansion there (the step, ~1e-10 of the range, cubed
        // is far under round-off, and the expansion is as much a function
        // of the grid's point as an evaluation: two of five of Gmsh's
        // calls per projection saved); evaluated where the step was not
        // taken whole (the range's side, a seam, a pole)
        let mut exact: Vec<usize> = Vec::new();
        let mut next: Vec<[f64; 2]> = Vec::with_capacity(n);
        let mut feet: Vec<Foot> = Vec::with_capacity(n);
        for j in 0..n {
            let x = [v[3 * j], v[3 * j + 1], v[3 * j + 2]];
            let d = tangents(&ds[3 * k * j..3 * k * (j + 1)], k);
            let dd = &dds[3 * seconds * j..3 * seconds * (j + 1)];
            let to = match newton_step(d, dd, sub(x, ps[j]), k) {
                Some(step) => {
                    let to = on_seam(step_in_range(uv[j], step, range, k), frame, k);
                    if (0..k).all(|l| to[l] == uv[j][l] + step[l]) {
                        let (x, d) = taylor(x, d, dd, step, k);
                        next.push(to);
                        feet.push(Foot { x, uv: to, d });
                        continue;
                    }
                    to
                }
                // (a pole, the medial axis) the converged foot stands
                None => converged[j].1,
            };
            exact.push(j);
            next.push(to);
            feet.push(Foot { x, uv: to, d });
        }
        if !exact.is_empty() {
            let at: Vec<[f64; 2]> = exact.iter().map(|&j| next[j]).collect();
            let v = s.value(self.dim, self.tag, &flat(&at))?;
            self.enough("gmshModelGetValue", &v, 3, at.len())?;
            let ds = s.derivative(self.dim, self.tag, &flat(&at))?;
            self.enough("gmshModelGetDerivative", &ds, 3 * k, at.len())?;
            for (i, &j) in exact.iter().enumerate() {
                feet[j] = Foot { x: [v[3 * i], v[3 * i + 1], v[3 * i + 2]], uv: next[j], d: tangents(&ds[3 * k * i..3 * k * (i + 1)], k) };
            }
        }
        // a settled foot farther than the converged one by more than
        // round-off went across a C0 knot or a seam that is not one (the
        // grid's half-step on the other branch): the converged foot stands
        let back: Vec<usize> = (0..n).filter(|&j| norm(sub(feet[j].x, ps[j])) > norm(sub(converged[j].0, ps[j])) + 1e-12 * size).collect();
        if !back.is_empty() {
            let ds = s.derivative(self.dim, self.tag, &flat(&back.iter().map(|&j| converged[j].1).collect::<Vec<_>>()))?;
            self.enough("gmshModelGetDerivative", &ds, 3 * k, back.len())?;
            for (i, &j) in back.iter().enumerate() {
                feet[j] = Foot { x: converged[j].0, uv: converged[j].1, d: tangents(&ds[3 * k * i..3 * k * (i + 1)], k) };
            }
        }
        Ok(feet)
    }

    /// An error unless Gmsh's `call` answered `per` values for each of `n`
    /// points.
    fn enough(&self, call: &str, v: &[f64], per: usize, n: usize) -> Result<(), CadError> {
        if v.len() < per * n {
            return Err(CadError::Gmsh { call: call.into(), message: format!("{} values for {n} points of entity ({}, {})", v.len(), self.dim, self.tag) });
        }
        Ok(())
    }

    /// The foot of `p` and the normal there: Newton's method from the foot
    /// of a query in `p`'s seed cell, else from Gmsh's projection (70 µs
    /// on a B-spline face against a few µs for Newton's evaluations).
    fn solve(&self, s: &gmsh::Session, known: &mut Known, p: [f64; 3], planar: bool) -> Result<Answer, CadError> {
        let frame = known.frame_of(self, s)?;
        let cell = p.map(|c| (c / frame.cell).floor() as i64);
        // the seed of p's own cell, else of the nearest cell around it
        // holding one (a point just across a cell's side from earlier
        // queries would otherwise go to Gmsh's projection, 5-10 times the
        // cost of Newton's steps: a third of the torus's queries did)
        let seeded = match seed_near(&known.seeds, cell) {
            Some(uv) => self.newton(s, p, uv, &frame, false)?,
            None => None,
        };
        let foot = match seeded {
            Some(f) => f,
            None => self.gmsh_foot(s, p, &frame)?,
        };
        known.seed(cell, foot.uv);
        let n = if self.dim == 2 { self.surface_normal(s, &foot, frame.sign)? } else { curve_normal(foot.d[0], sub(p, foot.x), planar) };
        Ok((foot.x, n, foot.uv))
    }

    /// The entity's parameter range, seed cell, and normal sign.
    fn frame(&self, s: &gmsh::Session) -> Result<Frame, CadError> {
        let (lo, hi) = s.parameter_bounds(self.dim, self.tag)?;
        let two = |v: &[f64]| [v.first().copied().unwrap_or(0.0), v.get(1).copied().unwrap_or(0.0)];
        let range = [two(&lo), two(&hi)];
        let [b0, b1] = s.bounding_box(self.dim, self.tag)?;
        let cell = SEED_CELL * norm(sub(b1, b0)).max(f64::MIN_POSITIVE);
        let mut sign = 1.0;
        if self.dim == 2 {
            // Gmsh's normal follows the face's orientation: compare once
            let mid = [0.5 * (range[0][0] + range[1][0]), 0.5 * (range[0][1] + range[1][1])];
            let d = s.derivative(2, self.tag, &mid)?;
            let c = cross3([d[0], d[1], d[2]], [d[3], d[4], d[5]]);
            let n = s.normal(self.tag, &mid)?;
            sign = if dot(c, [n[0], n[1], n[2]]) < 0.0 { -1.0 } else { 1.0 };
        }
        let closed = self.closed(s, range, norm(sub(b1, b0)))?;
        Ok(Frame { range, cell, sign, closed })
    }

    /// Whether the shape meets itself across each parameter's range: its
    /// points at the range's two ends (at three places along the other
    /// parameter of a surface) within 1e-12 of its size.
    fn closed(&self, s: &gmsh::Session, range: [[f64; 2]; 2], size: f64) -> Result<[bool; 2], CadError> {
        let k = self.dim as usize;
        let mut out = [false; 2];
        for (l, closed) in out.iter_mut().enumerate().take(k) {
            let o = 1 - l;
            let along: &[f64] = if k == 1 { &[0.0] } else { &[0.2, 0.5, 0.8] };
            let mut uv = Vec::new();
            for &w in along {
                for end in [range[0][l], range[1][l]] {
                    let mut q = [0.0; 2];
                    q[l] = end;
                    q[o] = range[0][o] + w * (range[1][o] - range[0][o]);
                    uv.extend_from_slice(&q[..k]);
                }
            }
            let v = s.value(self.dim, self.tag, &uv)?;
            self.enough("gmshModelGetValue", &v, 3, 2 * along.len())?;
            *closed = v[..6 * along.len()].chunks_exact(6).all(|e| norm(sub([e[0], e[1], e[2]], [e[3], e[4], e[5]])) <= 1e-12 * size);
        }
        Ok(out)
    }

    /// Gmsh's projection of `p`, polished by Newton's method (its own is
    /// only about 1e-9 of the model's size close; on curves its parameter
    /// is mostly 0, and at a curve's end it may answer the other end).
    fn gmsh_foot(&self, s: &gmsh::Session, p: [f64; 3], frame: &Frame) -> Result<Foot, CadError> {
        let range = frame.range;
        let (x, uv) = s.closest(self.dim, self.tag, &p)?;
        let k = self.dim as usize;
        if x.len() < 3 || uv.len() < k {
            return Err(CadError::Gmsh { call: "gmshModelGetClosestPoint".into(), message: format!("no point of entity ({}, {}) found", self.dim, self.tag) });
        }
        let mut start = ([x[0], x[1], x[2]], [uv[0], if k == 2 { uv[1] } else { 0.0 }]);
        if k == 1 {
            // Gmsh 4.15 answers most curve feet with parameter 0 (the
            // point itself is right): ask for the foot's parameter
            let t = s.parametrization(1, self.tag, &start.0)?;
            start.1[0] = t.first().copied().unwrap_or(start.1[0]);
            for end in [range[0][0], range[1][0]] {
                let e = s.value(1, self.tag, &[end])?;
                let e = [e[0], e[1], e[2]];
                if norm(sub(p, e)) < norm(sub(p, start.0)) {
                    start = (e, [end, 0.0]);
                }
            }
        }
        if let Some(f) = self.newton(s, p, start.1, frame, true)? {
            // Newton's foot unless it is another, farther one: where the
            // two are the same foot they tie to round-off (a point on a
            // circle), and taking Gmsh's there made the foot depend on
            // whether a seed was near (the order of the queries)
            let size = frame.cell / SEED_CELL;
            let (newton, gmsh) = (norm(sub(p, f.x)), norm(sub(p, start.0)));
            if newton <= gmsh || (norm(sub(f.x, start.0)) <= 1e-6 * size && newton <= gmsh + 1e-12 * size) {
                return Ok(f);
            }
        }
        let d = s.derivative(self.dim, self.tag, &start.1[..k])?;
        Ok(Foot { x: start.0, uv: start.1, d: tangents(&d, k) })
    }

    /// Newton's method on |S(uv) − p|² from `uv`, the parameters kept in
    /// `range`: the foot, or None where it does not converge (or the
    /// Hessian is not positive there: a point near the medial axis). A
    /// step beyond the range is cut back to it only where `edge` allows;
    /// else None: across a closed curve's or surface's seam the foot is on
    /// the range's other side, which Gmsh's projection finds.
    fn newton(&self, s: &gmsh::Session, p: [f64; 3], mut uv: [f64; 2], frame: &Frame, edge: bool) -> Result<Option<Foot>, CadError> {
        let range = frame.range;
        let k = self.dim as usize;
        let mut x = s.value(self.dim, self.tag, &uv[..k])?;
        for _ in 0..16 {
            let d = tangents(&s.derivative(self.dim, self.tag, &uv[..k])?, k);
            let dd = s.second_derivative(self.dim, self.tag, &uv[..k])?;
            let Some(step) = newton_step(d, &dd, sub([x[0], x[1], x[2]], p), k) else { return Ok(None) };
            let next = step_in_range(uv, step, range, k);
            if !edge && (0..k).any(|j| next[j] != uv[j] + step[j]) {
                return Ok(None);
            }
            let moved = (0..k).map(|j| (next[j] - uv[j]).abs() * norm(d[j])).fold(0.0, f64::max);
            uv = next;
            x = s.value(self.dim, self.tag, &uv[..k])?;
            // converging quadratically: after a step this short the foot
            // is at round-off (a tighter test would wait on round-off noise)
            if moved <= 1e-10 * (1.0 + norm(p)) {
                return Ok(self.settle(s, &[p], &[([x[0], x[1], x[2]], uv)], frame)?.pop());
            }
        }
        Ok(None)
    }

    /// The unit normal of the surface at `foot`: ∂u × ∂v turned as Gmsh's
    /// (`sign`), or Gmsh's own where the parametrisation degenerates (a
    /// sphere's pole).
    fn surface_normal(&self, s: &gmsh::Session, foot: &Foot, sign: f64) -> Result<[f64; 3], CadError> {
        let c = cross3(foot.d[0], foot.d[1]);
        if norm(c) > 1e-12 * dot(foot.d[0], foot.d[0]).max(dot(foot.d[1], foot.d[1])) {
            return Ok(unit(c).map(|v| sign * v));
        }
        let n = s.normal(self.tag, &foot.uv)?;
        Ok([n[0], n[1], n[2]])
    }
}

/// Newton's step on |S − p|² in the parameters, where S has the
/// tangents `d`, the second derivatives `dd` (x_tt, or x_uu, x_vv, x_uv)
/// and the offset `r` = S − p; None where the Hessian is not positive
/// (NaN included): a point near the medial axis.
fn newton_step(d: [[f64; 3]; 2], dd: &[f64], r: [f64; 3], k: usize) -> Option<[f64; 2]> {
    let [huu, hvv, huv, det] = hessian(d, dd, r, k)?;
    if k == 1 {
        return Some([-dot(d[0], r) / huu, 0.0]);
    }
    let (gu, gv) = (dot(d[0], r), dot(d[1], r));
    Some([-(hvv * gu - huv * gv) / det, -(huu * gv - huv * gu) / det])
}

/// Newton's Hessian of |S − p|² / 2 in the parameters (as
/// [`newton_step`]'s arguments): [h, 0, 0, h] on a curve, [huu, hvv, huv,
/// det] on a surface; None where it is not positive (NaN included).
fn hessian(d: [[f64; 3]; 2], dd: &[f64], r: [f64; 3], k: usize) -> Option<[f64; 4]> {
    let second = |l: usize| [dd[3 * l], dd[3 * l + 1], dd[3 * l + 2]];
    if k == 1 {
        let h = dot(d[0], d[0]) + dot(second(0), r);
        return (h > 0.0).then_some([h, 0.0, 0.0, h]);
    }
    let (huu, hvv, huv) = (dot(d[0], d[0]) + dot(second(0), r), dot(d[1], d[1]) + dot(second(1), r), dot(d[0], d[1]) + dot(second(2), r));
    let det = huu * hvv - huv * huv;
    (huu > 0.0 && det > 0.0).then_some([huu, hvv, huv, det])
}

/// The point and tangents at parameters `step` from a point `x` with
/// tangents `d` and second derivatives `dd` (as [`newton_step`]'s), to
/// second order in the point and first in the tangents.
fn taylor(x: [f64; 3], d: [[f64; 3]; 2], dd: &[f64], step: [f64; 2], k: usize) -> ([f64; 3], [[f64; 3]; 2]) {
    let second = |l: usize| [dd[3 * l], dd[3 * l + 1], dd[3 * l + 2]];
    // x_uu, x_vv, x_uv on a surface; x_tt on a curve
    let (uu, vv, uv) = if k == 1 { (second(0), [0.0; 3], [0.0; 3]) } else { (second(0), second(1), second(2)) };
    let (a, b) = (step[0], if k == 1 { 0.0 } else { step[1] });
    let x = std::array::from_fn(|c| x[c] + a * d[0][c] + b * d[1][c] + 0.5 * (a * a * uu[c] + 2.0 * a * b * uv[c] + b * b * vv[c]));
    let du = std::array::from_fn(|c| d[0][c] + a * uu[c] + b * uv[c]);
    let dv = if k == 1 { d[1] } else { std::array::from_fn(|c| d[1][c] + a * uv[c] + b * vv[c]) };
    (x, [du, dv])
}

/// The low and high ends of parameter `l`'s range.
fn bounds(range: [[f64; 2]; 2], l: usize) -> (f64, f64) {
    (range[0][l].min(range[1][l]), range[0][l].max(range[1][l]))
}

/// `uv + step` kept in the range (parameters past the `k`-th are 0).
fn step_in_range(uv: [f64; 2], step: [f64; 2], range: [[f64; 2]; 2], k: usize) -> [f64; 2] {
    std::array::from_fn(|l| {
        if l >= k {
            return 0.0;
        }
        let (lo, hi) = bounds(range, l);
        (uv[l] + step[l]).clamp(lo, hi)
    })
}

/// `uv` on the grid of 2⁻³⁰ of the parameter range (a power of two, so
/// the grid's points are exact), kept in the range ([`CadShape::settle`]).
fn on_grid(uv: [f64; 2], range: [[f64; 2]; 2], k: usize) -> [f64; 2] {
    std::array::from_fn(|l| {
        let (lo, hi) = bounds(range, l);
        let h = (hi - lo) * (-30f64).exp2();
        if l >= k || h.is_nan() || h <= 0.0 || h.is_infinite() {
            return uv[l];
        }
        (lo + ((uv[l] - lo) / h).round() * h).clamp(lo, hi)
    })
}

/// `uv` with each closed parameter within 1e-14 of its range of the
/// seam put at the range's low end. Why: a mesh vertex on a circle's seam
/// converges to 0 or to 2π (a few ulps inside) depending on its seed, and
/// the two ends' points differ in round-off, enough to turn a fit.
fn on_seam(uv: [f64; 2], frame: &Frame, k: usize) -> [f64; 2] {
    std::array::from_fn(|l| {
        let (lo, hi) = bounds(frame.range, l);
        let near = 1e-14 * (hi - lo);
        if l < k && frame.closed[l] && (uv[l] - lo <= near || hi - uv[l] <= near) {
            lo
        } else {
            uv[l]
        }
    })
}

/// Gmsh's first derivatives (x_u, then x_v for a surface) as vectors.
fn tangents(d: &[f64], k: usize) -> [[f64; 3]; 2] {
    std::array::from_fn(|j| if j < k && d.len() >= 3 * j + 3 { [d[3 * j], d[3 * j + 1], d[3 * j + 2]] } else { [0.0; 3] })
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

/// `p` in 3D (z = 0 for a point of the plane).
pub(crate) fn lift<const D: usize>(p: [f64; D]) -> [f64; 3] {
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

    fn closest_points(&self, ps: &[[f64; D]]) -> Vec<[f64; D]> {
        let lifted: Vec<[f64; 3]> = ps.iter().map(|&p| lift(p)).collect();
        self.project_all(&lifted, D == 2).into_iter().map(|r| drop_to(r.0)).collect()
    }

    fn serial(&self) -> bool {
        true
    }

    fn largest_sample_distance(&self, nodes: &[[f64; D]], weights: &[Vec<f64>]) -> f64 {
        let lifted: Vec<[f64; 3]> = nodes.iter().map(|&p| lift(p)).collect();
        CadShape::largest_sample_distance(self, &lifted, weights, D == 2)
    }

    fn foot_speeds(&self, ps: &[[f64; D]], dirs: &[[f64; D]]) -> Vec<Option<[f64; D]>> {
        let lifted: Vec<[f64; 3]> = ps.iter().map(|&p| lift(p)).collect();
        let dirs: Vec<[f64; 3]> = dirs.iter().map(|&p| lift(p)).collect();
        CadShape::foot_speeds(self, &lifted, &dirs, D == 2).into_iter().map(|v| v.map(drop_to)).collect()
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

