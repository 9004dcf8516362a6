//! Gmsh's C API (`gmshc.h`), opened at run time.
//!
//! Why at run time: Gmsh is GPL-2+ and a large library; the crate builds,
//! and every command but `curve --cad` runs, without it. It is found
//! through `DEFORMESH_GMSH_LIB` (the library file, or a folder holding
//! it), else the active Python's `gmsh` package (`pip install gmsh`
//! ships `lib/libgmsh.so.4.15`), else the system's library path
//! (Debian's `libgmsh-dev`).
//!
//! Gmsh keeps global state (one current model, not thread safe), so the
//! library and its models live in one process-wide [`Session`] behind a
//! mutex; each [`super::CadModel`] is a named Gmsh model made current
//! before every call.

use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use super::CadError;

/// The oldest Gmsh whose API matches the signatures below
/// (`gmshInitialize` took its `run` argument in 4.11).
pub const OLDEST: (u32, u32) = (4, 11);

type ErrPtr = *mut c_int;

/// The shape of Gmsh's evaluations of an entity: (dim, tag, inputs) →
/// an array Gmsh allocates (`GetValue`, `GetDerivative`, …).
type EvalFn = unsafe extern "C" fn(c_int, c_int, *const f64, usize, *mut *mut f64, *mut usize, ErrPtr);

/// The entry points of `libgmsh` the method calls, with their C types.
struct Api {
    free: unsafe extern "C" fn(*mut c_void),
    initialize: unsafe extern "C" fn(c_int, *mut *mut c_char, c_int, c_int, ErrPtr),
    option_set_number: unsafe extern "C" fn(*const c_char, f64, ErrPtr),
    option_get_string: unsafe extern "C" fn(*const c_char, *mut *mut c_char, ErrPtr),
    model_add: unsafe extern "C" fn(*const c_char, ErrPtr),
    model_set_current: unsafe extern "C" fn(*const c_char, ErrPtr),
    merge: unsafe extern "C" fn(*const c_char, ErrPtr),
    get_entities: unsafe extern "C" fn(*mut *mut c_int, *mut usize, c_int, ErrPtr),
    get_type: unsafe extern "C" fn(c_int, c_int, *mut *mut c_char, ErrPtr),
    get_boundary: unsafe extern "C" fn(*const c_int, usize, *mut *mut c_int, *mut usize, c_int, c_int, c_int, ErrPtr),
    closest_point: unsafe extern "C" fn(c_int, c_int, *const f64, usize, *mut *mut f64, *mut usize, *mut *mut f64, *mut usize, ErrPtr),
    get_value: EvalFn,
    get_derivative: EvalFn,
    get_bounding_box: unsafe extern "C" fn(c_int, c_int, *mut f64, *mut f64, *mut f64, *mut f64, *mut f64, *mut f64, ErrPtr),
    get_parametrization: EvalFn,
    get_second_derivative: EvalFn,
    get_normal: unsafe extern "C" fn(c_int, *const f64, usize, *mut *mut f64, *mut usize, ErrPtr),
    get_parametrization_bounds: unsafe extern "C" fn(c_int, c_int, *mut *mut f64, *mut usize, *mut *mut f64, *mut usize, ErrPtr),
    is_inside: unsafe extern "C" fn(c_int, c_int, *const f64, usize, c_int, ErrPtr) -> c_int,
    last_error: unsafe extern "C" fn(*mut *mut c_char, ErrPtr),
}

/// The loaded library, initialised, and which of our models is current.
pub struct Session {
    api: Api,
    // kept alive: the function pointers in `api` point into it
    _lib: libloading::Library,
    /// The library file.
    pub path: PathBuf,
    /// Gmsh's `General.Version`.
    pub version: String,
    current: Option<CString>,
    models: usize,
}

// Gmsh's calls are made only through the mutex below, one at a time.
unsafe impl Send for Session {}

static SESSION: Mutex<Option<Session>> = Mutex::new(None);

/// The process's Gmsh session, loading and initialising the library on
/// first use (`library`: a file or folder given by the caller, before
/// the search of [`find`]).
pub fn session(library: Option<&Path>) -> Result<MutexGuard<'static, Option<Session>>, CadError> {
    // a panic while the lock was held leaves Gmsh as it was: go on
    let mut guard = SESSION.lock().unwrap_or_else(|e| e.into_inner());
    if guard.is_none() {
        *guard = Some(Session::load(library)?);
    }
    Ok(guard)
}

/// The process's Gmsh session on the library at `library` that the
/// process has already loaded and initialised (the Python `gmsh` module's
/// `gmsh.libpath`): loading it again gives the same library and so the
/// same current model; Gmsh is not initialised again and no option is
/// changed. A session already loaded is kept (it is that library or the
/// process has two Gmsh, which it cannot use both of).
pub fn attach(library: &Path) -> Result<MutexGuard<'static, Option<Session>>, CadError> {
    let mut guard = SESSION.lock().unwrap_or_else(|e| e.into_inner());
    match guard.as_ref() {
        None => {
            // SAFETY: the library is loaded already; this only counts a reference
            let lib = unsafe { libloading::Library::new(library) }.map_err(|e| CadError::Absent { named: true, tried: vec![format!("{}: {e}", library.display())] })?;
            *guard = Some(Session::start(lib, library.to_path_buf(), false)?);
        }
        // another Gmsh's current model is not the caller's
        Some(s) if s.path.canonicalize().ok() != library.canonicalize().ok() => {
            return Err(CadError::Library {
                why: format!("this process has Gmsh's library `{}` open for deformesh already, and the caller's is `{}`: one process can use one Gmsh (unset DEFORMESH_GMSH_LIB)", s.path.display(), library.display()),
            });
        }
        Some(_) => {}
    }
    // the user may have made another model current since the last call
    guard.as_mut().expect("set above").current = None;
    Ok(guard)
}

/// Where to look for the library, in order, and the names tried.
fn candidates(library: Option<&Path>) -> Result<Vec<PathBuf>, CadError> {
    let names = ["libgmsh.so.4.15", "libgmsh.so", "libgmsh.so.4.14", "libgmsh.so.4.13", "libgmsh.so.4.12", "libgmsh.so.4.11", "libgmsh.dylib", "gmsh.dll"];
    let in_folder = |dir: &Path| names.iter().map(|n| dir.join(n)).collect::<Vec<_>>();
    let given = library.map(Path::to_path_buf).or_else(|| std::env::var_os("DEFORMESH_GMSH_LIB").map(PathBuf::from));
    if given.as_ref().is_some_and(|p| p.as_os_str().is_empty()) {
        // an empty name would load the running program itself
        return Err(CadError::Library {
            why: "DEFORMESH_GMSH_LIB is set but empty: set it to Gmsh's library file (e.g. .venv/lib/libgmsh.so.4.15) or a folder holding it, or unset it to search the Python `gmsh` package and the system path".into(),
        });
    }
    if let Some(p) = given {
        // a named place is the only one: falling back would hide the mistake
        return Ok(if p.is_dir() { in_folder(&p) } else { vec![p] });
    }
    let mut out = Vec::new();
    if let Some(p) = python_libpath() {
        out.push(p);
    }
    // bare names: the dynamic loader's search (LD_LIBRARY_PATH, ldconfig)
    out.extend(names.iter().map(PathBuf::from));
    Ok(out)
}

/// `gmsh.libpath` of the active Python (`$VIRTUAL_ENV`'s, else
/// `python3`'s), if it has the `gmsh` package.
fn python_libpath() -> Option<PathBuf> {
    let python = std::env::var_os("VIRTUAL_ENV").map(|v| PathBuf::from(v).join("bin/python")).filter(|p| p.exists()).unwrap_or_else(|| PathBuf::from("python3"));
    let out = std::process::Command::new(python).args(["-c", "import gmsh; print(gmsh.libpath or '')"]).stderr(std::process::Stdio::null()).output().ok()?;
    let text = String::from_utf8(out.stdout).ok()?;
    let p = PathBuf::from(text.trim());
    (out.status.success() && p.is_file()).then_some(p)
}

/// A function pointer of type `T` named `name` in `lib`.
pub(super) unsafe fn symbol<T: Copy>(lib: &libloading::Library, path: &Path, name: &str) -> Result<T, CadError> {
    let c = CString::new(name).expect("no NUL in a symbol name");
    unsafe { lib.get::<T>(c.as_bytes_with_nul()) }.map(|s| *s).map_err(|e| CadError::Library {
        why: format!("`{}` has no `{name}` ({e}): it is not Gmsh's library, or a Gmsh older than {}.{}", path.display(), OLDEST.0, OLDEST.1),
    })
}

/// While alive, what the process writes to its stdout (file descriptor 1)
/// goes to its stderr; restored when dropped.
struct StdoutToStderr {
    #[cfg(unix)]
    saved: libc::c_int,
}

impl StdoutToStderr {
    fn begin() -> StdoutToStderr {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        // SAFETY: dup and dup2 of the process's standard descriptors
        #[cfg(unix)]
        unsafe {
            libc::fflush(std::ptr::null_mut());
            let saved = libc::dup(1);
            if saved >= 0 {
                libc::dup2(2, 1);
            }
            StdoutToStderr { saved }
        }
        #[cfg(not(unix))]
        StdoutToStderr {}
    }
}

impl Drop for StdoutToStderr {
    fn drop(&mut self) {
        // SAFETY: C's buffers flushed into stderr, then fd 1 put back
        #[cfg(unix)]
        unsafe {
            libc::fflush(std::ptr::null_mut());
            if self.saved >= 0 {
                libc::dup2(self.saved, 1);
                libc::close(self.saved);
            }
        }
    }
}

impl Session {
    fn load(library: Option<&Path>) -> Result<Session, CadError> {
        let tried = candidates(library)?;
        let named = library.is_some() || std::env::var_os("DEFORMESH_GMSH_LIB").is_some();
        let mut why = Vec::new();
        for path in &tried {
            // SAFETY: loading Gmsh runs its static initialisers only
            match unsafe { libloading::Library::new(path) } {
                Ok(lib) => return Session::start(lib, path.clone(), true),
                // a bare name is the loader's search: said once below
                Err(e) if path.components().count() > 1 || named => why.push(format!("{}: {e}", path.display())),
                Err(_) => {}
            }
        }
        if !named {
            if !tried.iter().any(|p| p.components().count() > 1) {
                why.push("the Python `gmsh` package: not found (python3 -c \"import gmsh\")".into());
            }
            why.push("the system library path: no libgmsh.so (4.11 to 4.15)".into());
        }
        Err(CadError::Absent { named, tried: why })
    }

    fn start(lib: libloading::Library, path: PathBuf, initialize: bool) -> Result<Session, CadError> {
        // SAFETY: the types are those of gmshc.h (4.11 and later)
        let api = unsafe {
            Api {
                free: symbol(&lib, &path, "gmshFree")?,
                initialize: symbol(&lib, &path, "gmshInitialize")?,
                option_set_number: symbol(&lib, &path, "gmshOptionSetNumber")?,
                option_get_string: symbol(&lib, &path, "gmshOptionGetString")?,
                model_add: symbol(&lib, &path, "gmshModelAdd")?,
                model_set_current: symbol(&lib, &path, "gmshModelSetCurrent")?,
                merge: symbol(&lib, &path, "gmshMerge")?,
                get_entities: symbol(&lib, &path, "gmshModelGetEntities")?,
                get_type: symbol(&lib, &path, "gmshModelGetType")?,
                get_boundary: symbol(&lib, &path, "gmshModelGetBoundary")?,
                closest_point: symbol(&lib, &path, "gmshModelGetClosestPoint")?,
                get_value: symbol(&lib, &path, "gmshModelGetValue")?,
                get_derivative: symbol(&lib, &path, "gmshModelGetDerivative")?,
                get_bounding_box: symbol(&lib, &path, "gmshModelGetBoundingBox")?,
                get_parametrization: symbol(&lib, &path, "gmshModelGetParametrization")?,
                get_second_derivative: symbol(&lib, &path, "gmshModelGetSecondDerivative")?,
                get_normal: symbol(&lib, &path, "gmshModelGetNormal")?,
                get_parametrization_bounds: symbol(&lib, &path, "gmshModelGetParametrizationBounds")?,
                is_inside: symbol(&lib, &path, "gmshModelIsInside")?,
                last_error: symbol(&lib, &path, "gmshLoggerGetLastError")?,
            }
        };
        let mut s = Session { api, _lib: lib, path, version: String::new(), current: None, models: 0 };
        if initialize {
            let mut ierr = 0;
            // no configuration files, no GUI or batch run
            unsafe { (s.api.initialize)(0, std::ptr::null_mut(), 0, 0, &mut ierr) };
            s.check(ierr, "gmshInitialize")?;
            // quiet: errors come back through ierr and the logger
            s.set_option("General.Terminal", 0.0)?;
        }
        s.version = s.option_string("General.Version")?;
        let v: Vec<u32> = s.version.split('.').filter_map(|x| x.parse().ok()).collect();
        if v.len() < 2 || (v[0], v[1]) < OLDEST {
            return Err(CadError::Library { why: format!("`{}` is Gmsh {}; `--cad` needs Gmsh {}.{} or later (pip install gmsh)", s.path.display(), s.version, OLDEST.0, OLDEST.1) });
        }
        Ok(s)
    }

    /// The loaded library, for the calls of the live model ([`super::live`]).
    pub(super) fn library(&self) -> &libloading::Library {
        &self._lib
    }

    /// Ok, or Gmsh's last error for a call that set `ierr`.
    pub(super) fn check(&self, ierr: c_int, call: &str) -> Result<(), CadError> {
        if ierr == 0 {
            return Ok(());
        }
        let mut msg: *mut c_char = std::ptr::null_mut();
        let mut e2 = 0;
        unsafe { (self.api.last_error)(&mut msg, &mut e2) };
        let text = if msg.is_null() { String::new() } else { self.take_string(msg) };
        Err(CadError::Gmsh { call: call.to_string(), message: text })
    }

    pub(super) fn take_string(&self, p: *mut c_char) -> String {
        let s = unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned();
        unsafe { (self.api.free)(p.cast()) };
        s
    }

    /// Copies Gmsh's array and frees it.
    pub(super) fn take<T: Copy>(&self, p: *mut T, n: usize) -> Vec<T> {
        if p.is_null() {
            return Vec::new();
        }
        let v = unsafe { std::slice::from_raw_parts(p, n) }.to_vec();
        unsafe { (self.api.free)(p.cast()) };
        v
    }

    pub(super) fn set_option(&self, name: &str, value: f64) -> Result<(), CadError> {
        let c = CString::new(name).expect("option names have no NUL");
        let mut ierr = 0;
        unsafe { (self.api.option_set_number)(c.as_ptr(), value, &mut ierr) };
        self.check(ierr, name)
    }

    fn option_string(&mut self, name: &str) -> Result<String, CadError> {
        let c = CString::new(name).expect("option names have no NUL");
        let (mut p, mut ierr) = (std::ptr::null_mut(), 0);
        unsafe { (self.api.option_get_string)(c.as_ptr(), &mut p, &mut ierr) };
        self.check(ierr, name)?;
        Ok(if p.is_null() { String::new() } else { self.take_string(p) })
    }

    /// Reads `file` into a new model of its own, its coordinates times
    /// `scale` (Gmsh's `Geometry.OCCScaling`: STEP, IGES and BREP read by
    /// OpenCASCADE); returns the model's name.
    pub fn open(&mut self, file: &Path, scale: f64) -> Result<CString, CadError> {
        self.models += 1;
        let name = CString::new(format!("deformesh-cad-{}", self.models)).expect("no NUL");
        let path = CString::new(file.to_string_lossy().into_owned()).map_err(|_| CadError::Gmsh { call: "gmshMerge".into(), message: "the path has a NUL byte".into() })?;
        let mut ierr = 0;
        unsafe { (self.api.model_add)(name.as_ptr(), &mut ierr) };
        self.check(ierr, "gmshModelAdd")?;
        self.current = Some(name.clone());
        // OpenCASCADE prints its diagnostics to stdout, which is the
        // user's (a pipe of our figures): they go to stderr
        let _stdout = StdoutToStderr::begin();
        self.set_option("Geometry.OCCScaling", scale)?;
        unsafe { (self.api.merge)(path.as_ptr(), &mut ierr) };
        drop(_stdout);
        // the next model is read at its own scale
        let reset = self.set_option("Geometry.OCCScaling", 1.0);
        self.check(ierr, "gmshMerge")?;
        reset?;
        Ok(name)
    }

    /// Makes `model` current (cheap when it is).
    pub fn select(&mut self, model: &CString) -> Result<(), CadError> {
        if self.current.as_ref() == Some(model) {
            return Ok(());
        }
        let mut ierr = 0;
        unsafe { (self.api.model_set_current)(model.as_ptr(), &mut ierr) };
        self.check(ierr, "gmshModelSetCurrent")?;
        self.current = Some(model.clone());
        Ok(())
    }

    /// The (dim, tag) of every entity of dimension `dim` of the current model.
    pub fn entities(&self, dim: i32) -> Result<Vec<(i32, i32)>, CadError> {
        let (mut p, mut n, mut ierr) = (std::ptr::null_mut(), 0usize, 0);
        unsafe { (self.api.get_entities)(&mut p, &mut n, dim, &mut ierr) };
        self.check(ierr, "gmshModelGetEntities")?;
        Ok(self.take(p, n).chunks(2).map(|c| (c[0], c[1])).collect())
    }

    /// The entity's type: "Plane", "Line", "BSpline surface", …
    pub fn entity_type(&self, dim: i32, tag: i32) -> Result<String, CadError> {
        let (mut p, mut ierr) = (std::ptr::null_mut(), 0);
        unsafe { (self.api.get_type)(dim, tag, &mut p, &mut ierr) };
        self.check(ierr, "gmshModelGetType")?;
        Ok(if p.is_null() { String::new() } else { self.take_string(p) })
    }

    /// The tags of the entities of dimension `dim − 1` bounding (dim, tag).
    pub fn boundary(&self, dim: i32, tag: i32) -> Result<Vec<i32>, CadError> {
        let dt = [dim, tag];
        let (mut p, mut n, mut ierr) = (std::ptr::null_mut(), 0usize, 0);
        unsafe { (self.api.get_boundary)(dt.as_ptr(), 2, &mut p, &mut n, 0, 0, 0, &mut ierr) };
        self.check(ierr, "gmshModelGetBoundary")?;
        Ok(self.take(p, n).chunks(2).map(|c| c[1].abs()).collect())
    }

    /// The closest points of (dim, tag) to `points` (x, y, z each) and
    /// their parameters (1 or 2 each).
    pub fn closest(&self, dim: i32, tag: i32, points: &[f64]) -> Result<(Vec<f64>, Vec<f64>), CadError> {
        let (mut xp, mut xn, mut up, mut un, mut ierr) = (std::ptr::null_mut(), 0usize, std::ptr::null_mut(), 0usize, 0);
        unsafe { (self.api.closest_point)(dim, tag, points.as_ptr(), points.len(), &mut xp, &mut xn, &mut up, &mut un, &mut ierr) };
        self.check(ierr, "gmshModelGetClosestPoint")?;
        Ok((self.take(xp, xn), self.take(up, un)))
    }

    /// Gmsh's evaluation `f` (named `call`) of entity (dim, tag) at `input`.
    fn evaluate(&self, f: EvalFn, call: &str, (dim, tag): (i32, i32), input: &[f64]) -> Result<Vec<f64>, CadError> {
        let (mut p, mut n, mut ierr) = (std::ptr::null_mut(), 0usize, 0);
        unsafe { f(dim, tag, input.as_ptr(), input.len(), &mut p, &mut n, &mut ierr) };
        self.check(ierr, call)?;
        Ok(self.take(p, n))
    }

    /// The points of (dim, tag) at parameters `uv` (for a point entity:
    /// its coordinates).
    pub fn value(&self, dim: i32, tag: i32, uv: &[f64]) -> Result<Vec<f64>, CadError> {
        self.evaluate(self.api.get_value, "gmshModelGetValue", (dim, tag), uv)
    }

    /// The first derivatives of (dim, tag) at `uv`: per point, x_t (a
    /// curve) or x_u then x_v (a surface).
    pub fn derivative(&self, dim: i32, tag: i32, uv: &[f64]) -> Result<Vec<f64>, CadError> {
        self.evaluate(self.api.get_derivative, "gmshModelGetDerivative", (dim, tag), uv)
    }

    /// The bounding box `[min, max]` of (dim, tag).
    pub fn bounding_box(&self, dim: i32, tag: i32) -> Result<[[f64; 3]; 2], CadError> {
        let (mut b, mut ierr) = ([[0.0; 3]; 2], 0);
        let [lo, hi] = &mut b;
        let [x0, y0, z0] = lo;
        let [x1, y1, z1] = hi;
        unsafe { (self.api.get_bounding_box)(dim, tag, x0, y0, z0, x1, y1, z1, &mut ierr) };
        self.check(ierr, "gmshModelGetBoundingBox")?;
        Ok(b)
    }

    /// The parameters of `points` (x, y, z each) on (dim, tag).
    pub fn parametrization(&self, dim: i32, tag: i32, points: &[f64]) -> Result<Vec<f64>, CadError> {
        self.evaluate(self.api.get_parametrization, "gmshModelGetParametrization", (dim, tag), points)
    }

    /// The second derivatives of (dim, tag) at `uv`: per point, x_tt (a
    /// curve) or x_uu, x_vv, x_uv (a surface).
    pub fn second_derivative(&self, dim: i32, tag: i32, uv: &[f64]) -> Result<Vec<f64>, CadError> {
        self.evaluate(self.api.get_second_derivative, "gmshModelGetSecondDerivative", (dim, tag), uv)
    }

    /// The parameter ranges `(min, max)` of (dim, tag), one per parameter.
    pub fn parameter_bounds(&self, dim: i32, tag: i32) -> Result<(Vec<f64>, Vec<f64>), CadError> {
        let (mut lo, mut nlo, mut hi, mut nhi, mut ierr) = (std::ptr::null_mut(), 0usize, std::ptr::null_mut(), 0usize, 0);
        unsafe { (self.api.get_parametrization_bounds)(dim, tag, &mut lo, &mut nlo, &mut hi, &mut nhi, &mut ierr) };
        self.check(ierr, "gmshModelGetParametrizationBounds")?;
        Ok((self.take(lo, nlo), self.take(hi, nhi)))
    }

    /// The unit normals of surface `tag` at `uv`.
    pub fn normal(&self, tag: i32, uv: &[f64]) -> Result<Vec<f64>, CadError> {
        let (mut p, mut n, mut ierr) = (std::ptr::null_mut(), 0usize, 0);
        unsafe { (self.api.get_normal)(tag, uv.as_ptr(), uv.len(), &mut p, &mut n, &mut ierr) };
        self.check(ierr, "gmshModelGetNormal")?;
        Ok(self.take(p, n))
    }

    /// How many of `points` (x, y, z each) lie on entity (dim, tag): for a
    /// face, inside its trimming curves (a closest point on the untrimmed
    /// surface may lie in a hole of the face).
    pub fn count_inside(&self, dim: i32, tag: i32, points: &[f64]) -> Result<usize, CadError> {
        let mut ierr = 0;
        let n = unsafe { (self.api.is_inside)(dim, tag, points.as_ptr(), points.len(), 0, &mut ierr) };
        self.check(ierr, "gmshModelIsInside")?;
        Ok(n.max(0) as usize)
    }
}
