//! A run's output files written into a folder as one set.
//!
//! Two runs into one folder must never mix their files, a rerun must not
//! leave an earlier run's frames beside its own, and neither a failed write
//! nor Ctrl-C may leave staged files behind. So the folder is locked while a
//! set is written (`flock` on the folder itself: no lock file that could go
//! stale); every file is first staged under a hidden name, then all are
//! renamed into place, then what the earlier run of the same output wrote
//! and this run did not write is removed. Whether the folder can take the
//! files is checked before any computing ([`check_run_folder`],
//! [`check_output_file`], [`check_set`]).
//!
//! No run replaces or removes a file it did not write: the report records
//! every file a run wrote with its size and an FNV-1a hash of its bytes
//! ([`Written`], the report's `written`), and an existing file is replaced
//! only while it is still what a report of ours recorded (else the run is
//! refused before computing, unless [`Claim::force`]), and removed only
//! when it also belongs to the same output ([`Claim::output`]) and this run
//! does not write it again. The run's inputs are never replaced or removed.

use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicI32, AtomicUsize, Ordering};

/// Errors of the output folder; each names the path at fault.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    /// The output folder (or a folder above it) is an existing file.
    #[error("output folder `{}`: `{}` is a file, not a folder", folder.display(), file.display())]
    NotAFolder {
        /// The output folder asked for.
        folder: PathBuf,
        /// The file in its place.
        file: PathBuf,
    },
    /// The output file is an existing folder.
    #[error("output `{}` is a folder; name the file to write (e.g. `{}`)", .0.display(), .0.join("curved.msh").display())]
    FileIsFolder(PathBuf),
    /// The folder holds files of something else.
    #[error("output folder `{}` is not empty (it holds `{found}`) and has no {report} of an earlier run: choose a new or empty folder (or --force to write beside its files)", folder.display())]
    NotOurs {
        /// The folder.
        folder: PathBuf,
        /// One file found in it.
        found: String,
        /// The report that marks a folder written by this tool.
        report: String,
    },
    /// An output's name is taken by a file that no run of this tool wrote
    /// (or that changed since): it is not replaced without `--force`.
    #[error("`{}` exists and {why}: it is not replaced; nothing was written. Move it away, choose another output name, or pass --force to replace it", path.display())]
    NotWritten {
        /// The file.
        path: PathBuf,
        /// Why it is not ours.
        why: String,
    },
    /// An output's name is a file this run reads.
    #[error("`{}` is an input of this run ({what}): an output never replaces it; choose another output name", path.display())]
    IsInput {
        /// The output path.
        path: PathBuf,
        /// Which input.
        what: String,
    },
    /// Checking the folder failed (before any computing).
    #[error("cannot write `{}`", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// Writing, renaming or removing the files failed (a full disk, an
    /// I/O error); nothing staged is left.
    #[error("writing `{}` failed; nothing was written", path.display())]
    Write {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
}

impl FolderError {
    /// Whether the file system failed the write (a full disk, a quota, an
    /// I/O error, a file size limit), not the paths the user gave.
    pub fn is_write_failure(&self) -> bool {
        match self {
            FolderError::Write { source, .. } => source.kind() != io::ErrorKind::Interrupted,
            FolderError::Io { source, .. } => matches!(source.kind(), io::ErrorKind::StorageFull | io::ErrorKind::QuotaExceeded | io::ErrorKind::FileTooLarge),
            _ => false,
        }
    }
}

fn io_at(path: &Path) -> impl FnOnce(io::Error) -> FolderError + '_ {
    move |source| FolderError::Io { path: path.to_path_buf(), source }
}

fn write_at(path: &Path) -> impl FnOnce(io::Error) -> FolderError + '_ {
    move |source| FolderError::Write { path: path.to_path_buf(), source }
}

/// What a set of outputs may replace, and what it must never touch.
#[derive(Clone, Debug, Default)]
pub struct Claim {
    /// The output the set is, by its main file's name (`curve -o
    /// d/wing.msh`: `wing.msh`; `run`: `mesh.msh`). A rerun of the same
    /// output removes the earlier files of that output it does not write
    /// again; files of other outputs in the folder stay (and stay recorded
    /// as ours while unchanged).
    pub output: String,
    /// The files the run reads, with what each is (the input mesh, the
    /// geometry file, the CAD model): never replaced or removed, even with
    /// `force`.
    pub inputs: Vec<(PathBuf, String)>,
    /// `--force`: an existing file of an output's name that no run of ours
    /// wrote may be replaced (never removed, never an input).
    pub force: bool,
}

/// A file a run wrote, as its report records it (`written`): a later run
/// may replace or remove it only while it is still these bytes.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Written {
    /// Its name in the folder.
    pub file: String,
    /// The output it belongs to ([`Claim::output`]).
    pub output: String,
    /// Its size.
    pub bytes: u64,
    /// FNV-1a (64 bits) of its bytes, 16 hexadecimal digits.
    pub fnv1a64: String,
}

impl Written {
    /// The record of `bytes` written as `file` of `output`.
    pub fn of(file: &str, output: &str, bytes: &[u8]) -> Written {
        Written { file: file.to_string(), output: output.to_string(), bytes: bytes.len() as u64, fnv1a64: format!("{:016x}", fnv1a64(bytes)) }
    }

    /// Whether the file in `dir` is still what was written: a plain file
    /// of that size and hash.
    fn still_in(&self, dir: &Path) -> bool {
        let path = dir.join(&self.file);
        match fs::symlink_metadata(&path) {
            Ok(m) if m.is_file() && m.len() == self.bytes => fs::read(&path).is_ok_and(|b| format!("{:016x}", fnv1a64(&b)) == self.fnv1a64),
            _ => false,
        }
    }
}

/// FNV-1a, 64 bits: a fingerprint of a file's bytes (not a defence against
/// a forger, who could as well edit the report).
fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

/// What a folder's report says of earlier runs.
enum Ledger {
    /// No report.
    Absent,
    /// A report of ours: the files it records as written (none in a
    /// report of a version that recorded no hashes).
    Ours(Vec<Written>),
    /// A report of ours from a version that recorded no sizes and
    /// hashes: none of its files can be told to be as it wrote them.
    Unrecorded,
    /// A file of the report's name that is not a report of ours.
    Foreign,
}

/// Reads the ledger of `dir`'s `report` (JSON with an `outputs` list, and
/// `written` records); only plain visible names, so a doctored report
/// cannot make a rerun touch anything outside the folder.
fn ledger(dir: &Path, report: &str) -> Ledger {
    let path = dir.join(report);
    if fs::symlink_metadata(&path).is_err() {
        return Ledger::Absent;
    }
    let Some(value) = fs::read_to_string(&path).ok().and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok()) else {
        return Ledger::Foreign;
    };
    if !value.get("outputs").is_some_and(|o| o.is_array()) {
        return Ledger::Foreign;
    }
    let plain = |n: &str| !n.is_empty() && !n.starts_with('.') && !n.contains(['/', '\\']) && n != report;
    let Some(written) = value.get("written").and_then(|w| w.as_array()) else {
        return Ledger::Unrecorded;
    };
    Ledger::Ours(written.iter().filter_map(|w| serde_json::from_value::<Written>(w.clone()).ok()).filter(|w| plain(&w.file)).collect())
}

/// Whether two paths name one file (both must exist).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (fs::metadata(a), fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
        false
    }
    #[cfg(not(unix))]
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// Checks that the files `names` (the report among them) may be written
/// into `dir`: none is an input of the run or a folder, and each that
/// exists is one a report of ours recorded and that is unchanged since
/// (the report itself: a report of ours), unless `claim.force`. Done
/// before any computing, and again under the lock before writing.
pub fn check_set(dir: &Path, names: &[String], report: &str, claim: &Claim) -> Result<(), FolderError> {
    let ledger = ledger(dir, report);
    for name in names {
        let path = dir.join(name);
        if let Some((_, what)) = claim.inputs.iter().find(|(input, _)| same_file(input, &path)) {
            return Err(FolderError::IsInput { path, what: what.clone() });
        }
        let Ok(meta) = fs::symlink_metadata(&path) else { continue };
        if meta.is_dir() {
            return Err(FolderError::Io { path, source: io::Error::new(io::ErrorKind::IsADirectory, "a folder of that name is in the way") });
        }
        if claim.force {
            continue;
        }
        let why = match &ledger {
            Ledger::Ours(_) | Ledger::Unrecorded if name == report => continue,
            Ledger::Ours(written) => match written.iter().find(|w| &w.file == name) {
                Some(w) if w.still_in(dir) => continue,
                Some(_) => format!("changed since deformesh wrote it (its size or bytes differ from what `{report}` recorded)"),
                None => format!("was not written by deformesh (`{report}` does not record it)"),
            },
            Ledger::Absent => format!("was not written by deformesh (no report `{report}` records it)"),
            Ledger::Unrecorded => format!("cannot be told to be as deformesh wrote it (`{report}` is from a version that recorded no sizes and hashes: --force replaces it once)"),
            Ledger::Foreign if name == report => "is not a report of deformesh".to_string(),
            Ledger::Foreign => format!("was not written by deformesh (`{report}` is not a report of deformesh)"),
        };
        return Err(FolderError::NotWritten { path, why });
    }
    Ok(())
}

/// Checks, before any computing, that the folder `dir` can take a run's
/// outputs: it is a folder (or can be made one), writable, and either
/// empty or written earlier by this tool (it holds `report`), or `force`.
pub fn check_run_folder(dir: &Path, report: &str, force: bool) -> Result<(), FolderError> {
    if dir.is_dir() && !force {
        check_ours(dir, report)?;
    }
    check_writable(dir, dir)
}

/// Checks, before any computing, that the file `path` can be written: it is
/// not a folder and its folder is (or can be made) a writable folder.
pub fn check_output_file(path: &Path) -> Result<(), FolderError> {
    if path.is_dir() {
        return Err(FolderError::FileIsFolder(path.to_path_buf()));
    }
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    check_writable(dir, dir)
}

/// `folder` is, or can be created as, a folder we may write in: its nearest
/// existing ancestor must be a folder that takes a probe file.
fn check_writable(folder: &Path, dir: &Path) -> Result<(), FolderError> {
    let mut at = dir;
    while !at.exists() {
        match at.parent() {
            Some(p) if !p.as_os_str().is_empty() => at = p,
            _ => at = Path::new("."),
        }
    }
    if !at.is_dir() {
        return Err(FolderError::NotAFolder { folder: folder.to_path_buf(), file: at.to_path_buf() });
    }
    let probe = at.join(format!(".deformesh-probe-{}", std::process::id()));
    fs::File::create(&probe).map_err(io_at(folder))?;
    let _ = fs::remove_file(&probe);
    Ok(())
}

/// An existing folder is ours when it is empty (staged leftovers aside) or
/// holds a report of an earlier run; anything else might be a user's files,
/// which a rerun must neither mix with nor delete.
fn check_ours(dir: &Path, report: &str) -> Result<(), FolderError> {
    if matches!(ledger(dir, report), Ledger::Ours(_) | Ledger::Unrecorded) {
        return Ok(());
    }
    let names = fs::read_dir(dir).map_err(io_at(dir))?;
    let found = names.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).find(|n| !is_staged(n));
    match found {
        None => Ok(()),
        Some(found) => Err(FolderError::NotOurs { folder: dir.to_path_buf(), found, report: report.to_string() }),
    }
}

/// Names of staged files: `.<name>.staged-<pid>`.
fn is_staged(name: &str) -> bool {
    name.starts_with('.') && name.contains(".staged-")
}

/// Writes `files` (name, bytes) and the report `report` (the JSON object
/// `report_json`, to which its `written` records are added) into `dir` as
/// one set, creating `dir` if needed: locked against other runs, checked
/// again ([`check_set`]), staged, renamed into place, then the files of
/// the earlier run of the same output that this set does not write again
/// are removed, if still as written. On failure nothing staged is left,
/// nor a folder this call created.
pub fn write_set(dir: &Path, files: &[(String, Vec<u8>)], report: &str, report_json: serde_json::Value, claim: &Claim) -> Result<(), FolderError> {
    // dropped last: a Ctrl-C during the write takes effect after the cleanup
    let _writing = Writing::begin();
    let created = !dir.exists();
    fs::create_dir_all(dir).map_err(write_at(dir))?;
    let result = locked_write(dir, files, (report, report_json), claim);
    if result.is_err() && created {
        let _ = fs::remove_dir(dir);
    }
    result
}

fn locked_write(dir: &Path, files: &[(String, Vec<u8>)], (report, mut report_json): (&str, serde_json::Value), claim: &Claim) -> Result<(), FolderError> {
    let _lock = lock(dir)?;
    interrupted(dir)?;
    // under the lock, staged files are leftovers of a killed run
    for e in fs::read_dir(dir).map_err(write_at(dir))?.filter_map(|e| e.ok()) {
        if is_staged(&e.file_name().to_string_lossy()) {
            let _ = fs::remove_file(e.path());
        }
    }
    let names: Vec<String> = files.iter().map(|f| f.0.clone()).chain([report.to_string()]).collect();
    check_set(dir, &names, report, claim)?;
    let earlier = match ledger(dir, report) {
        Ledger::Ours(w) => w,
        _ => Vec::new(),
    };
    // what this set writes, and the earlier files it does not write again:
    // the same output's are removed, other outputs' stay recorded; either
    // only while still as written, and never an input
    let mut written: Vec<Written> = files.iter().map(|(n, b)| Written::of(n, &claim.output, b)).collect();
    let mut remove = Vec::new();
    for w in earlier.into_iter().filter(|w| !names.contains(&w.file)) {
        let path = dir.join(&w.file);
        if !w.still_in(dir) || claim.inputs.iter().any(|(input, _)| same_file(input, &path)) || written.iter().any(|x| x.file == w.file) {
            continue;
        }
        if w.output == claim.output {
            remove.push(path);
        } else {
            written.push(w);
        }
    }
    if let Some(object) = report_json.as_object_mut() {
        object.insert("written".into(), serde_json::to_value(&written).expect("records serialise"));
    }
    let report_bytes = serde_json::to_string_pretty(&report_json).expect("report serialises").into_bytes();
    let mut staged = Staged(Vec::new());
    for (name, bytes) in files.iter().map(|(n, b)| (n.as_str(), b.as_slice())).chain([(report, report_bytes.as_slice())]) {
        let tmp = dir.join(format!(".{name}.staged-{}", std::process::id()));
        staged.0.push((tmp.clone(), dir.join(name)));
        write_and_sync(&tmp, bytes).map_err(write_at(&dir.join(name)))?;
        pause_for_tests();
        interrupted(dir)?;
    }
    for (_, path) in &staged.0 {
        if fs::symlink_metadata(path).is_ok_and(|m| m.is_dir()) {
            return Err(FolderError::Io { path: path.clone(), source: io::Error::new(io::ErrorKind::IsADirectory, "a folder of that name is in the way") });
        }
    }
    while let Some((tmp, path)) = staged.0.first().cloned() {
        fs::rename(&tmp, &path).map_err(write_at(&path))?;
        staged.0.remove(0);
        pause_for_tests();
    }
    for path in remove {
        fs::remove_file(&path).map_err(write_at(&path))?;
    }
    Ok(())
}

/// Creates `path`, writes `bytes` and syncs, so the rename that follows
/// cannot expose a file whose data is still only in the page cache.
fn write_and_sync(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut file = fs::File::create(path)?;
    file.write_all(bytes)?;
    file.sync_all()
}

/// Staged files not yet renamed into place (staged path, final path);
/// removed when dropped, whichever way the write ends.
struct Staged(Vec<(PathBuf, PathBuf)>);

impl Drop for Staged {
    fn drop(&mut self) {
        for (tmp, _) in &self.0 {
            let _ = fs::remove_file(tmp);
        }
    }
}

/// An exclusive lock on the folder, held until dropped; another run
/// writing into the same folder waits for it.
#[cfg(unix)]
fn lock(dir: &Path) -> Result<fs::File, FolderError> {
    let f = fs::File::open(dir).map_err(io_at(dir))?;
    f.lock().map_err(io_at(dir))?;
    Ok(f)
}

#[cfg(not(unix))]
fn lock(_dir: &Path) -> Result<(), FolderError> {
    Ok(())
}

/// A test hook (debug builds only): sleeps this many milliseconds after
/// each staged file and each rename, so a test can interrupt a write or
/// start a second run while the first is writing.
fn pause_for_tests() {
    #[cfg(debug_assertions)]
    if let Some(ms) = std::env::var("DEFORMESH_TEST_WRITE_PAUSE_MS").ok().and_then(|v| v.parse().ok()) {
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
}

// ------------------------------------------------------------ Ctrl-C

/// Writes in progress; while any is, a SIGINT or SIGTERM is deferred.
static WRITERS: AtomicUsize = AtomicUsize::new(0);
/// The deferred signal (0: none).
static SIGNAL: AtomicI32 = AtomicI32::new(0);

/// Fails when a signal arrived during the write, so the staged files are
/// removed before the process ends.
fn interrupted(dir: &Path) -> Result<(), FolderError> {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => Ok(()),
        _ => Err(FolderError::Io { path: dir.to_path_buf(), source: io::Error::new(io::ErrorKind::Interrupted, "interrupted") }),
    }
}

/// Marks a write in progress for the signal handler.
struct Writing;

impl Writing {
    fn begin() -> Writing {
        WRITERS.fetch_add(1, Ordering::SeqCst);
        Writing
    }
}

impl Drop for Writing {
    fn drop(&mut self) {
        // decrement before reading SIGNAL and the handler does the opposite,
        // so a signal is never lost between the two (both may act: harmless)
        WRITERS.fetch_sub(1, Ordering::SeqCst);
        let sig = SIGNAL.load(Ordering::SeqCst);
        if sig != 0 {
            die(sig);
        }
    }
}

/// Installs the SIGINT and SIGTERM handler of the command line: outside
/// an output write the signal ends the process as usual; during one it is
/// deferred until the staged files are removed (or all renamed into place).
pub fn install_interrupt_handler() {
    #[cfg(unix)]
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: the handler only touches atomics and calls signal/raise,
        // which are async-signal-safe.
        unsafe {
            libc::signal(sig, on_signal as *const () as libc::sighandler_t);
        }
    }
}

#[cfg(unix)]
extern "C" fn on_signal(sig: libc::c_int) {
    SIGNAL.store(sig, Ordering::SeqCst);
    if WRITERS.load(Ordering::SeqCst) == 0 {
        die(sig);
    }
}

/// Ends the process by `sig` with its default action, as if no handler
/// had been installed (the shell then sees the usual status), saying so
/// on stderr first.
fn die(sig: i32) {
    #[cfg(unix)]
    // SAFETY: async-signal-safe calls only (write, signal, raise).
    unsafe {
        let said: &[u8] = if sig == libc::SIGINT {
            b"\ndeformesh: interrupted (SIGINT): the outputs are written whole or not at all\n"
        } else {
            b"\ndeformesh: terminated (SIGTERM): the outputs are written whole or not at all\n"
        };
        libc::write(2, said.as_ptr().cast(), said.len());
        libc::signal(sig, libc::SIG_DFL);
        libc::raise(sig);
    }
    #[cfg(not(unix))]
    std::process::exit(128 + sig);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    /// The files `names` (each holding its own name) and their report.
    fn set(names: &[&str]) -> (Vec<(String, Vec<u8>)>, serde_json::Value) {
        let outputs: Vec<&str> = names.iter().copied().chain(["report.json"]).collect();
        (names.iter().map(|n| (n.to_string(), n.as_bytes().to_vec())).collect(), serde_json::json!({ "outputs": outputs }))
    }

    fn claim(output: &str) -> Claim {
        Claim { output: output.into(), ..Claim::default() }
    }

    fn write(dir: &Path, files: &[&str], output: &str) -> Result<(), FolderError> {
        let (files, report) = set(files);
        write_set(dir, &files, "report.json", report, &claim(output))
    }

    #[test]
    fn a_rerun_removes_the_earlier_runs_files_only() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        write(&out, &["mesh.msh", "frame_t0.30.png", "deformation.gif"], "mesh.msh").unwrap();
        fs::write(out.join("notes.txt"), "mine").unwrap();
        check_run_folder(&out, "report.json", false).unwrap();
        write(&out, &["mesh.msh"], "mesh.msh").unwrap();
        assert_eq!(names(&out), ["mesh.msh", "notes.txt", "report.json"]);
    }

    #[test]
    fn a_file_changed_since_it_was_written_is_neither_replaced_nor_removed() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        write(&out, &["mesh.msh", "frame.png", "mesh.png"], "mesh.msh").unwrap();
        // the same size, other bytes: the hash tells
        fs::write(out.join("frame.png"), "FRAME.png").unwrap();
        write(&out, &["mesh.msh"], "mesh.msh").unwrap();
        assert_eq!(names(&out), ["frame.png", "mesh.msh", "report.json"]);
        assert_eq!(fs::read(out.join("frame.png")).unwrap(), b"FRAME.png");
        fs::write(out.join("mesh.msh"), "edited").unwrap();
        let e = write(&out, &["mesh.msh", "mesh.png"], "mesh.msh").unwrap_err();
        assert!(matches!(e, FolderError::NotWritten { .. }) && e.to_string().contains("mesh.msh") && e.to_string().contains("changed since deformesh wrote it"), "{e}");
        assert_eq!(fs::read(out.join("mesh.msh")).unwrap(), b"edited");
        assert_eq!(names(&out), ["frame.png", "mesh.msh", "report.json"], "nothing written");
        let (files, report) = set(&["mesh.msh", "mesh.png"]);
        write_set(&out, &files, "report.json", report, &Claim { force: true, ..claim("mesh.msh") }).unwrap();
        assert_eq!(fs::read(out.join("mesh.msh")).unwrap(), b"mesh.msh");
    }

    #[test]
    fn another_output_of_the_same_stem_keeps_the_first_outputs_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        write(out, &["wing.msh", "wing.vtu"], "wing.msh").unwrap();
        write(out, &["wing.mesh", "wing.vtu"], "wing.mesh").unwrap();
        assert_eq!(names(out), ["report.json", "wing.mesh", "wing.msh", "wing.vtu"]);
        // still recorded as ours: the first output may be written again,
        // and the second's files stay
        write(out, &["wing.msh"], "wing.msh").unwrap();
        assert_eq!(names(out), ["report.json", "wing.mesh", "wing.msh", "wing.vtu"]);
        let report: serde_json::Value = serde_json::from_str(&fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
        let recorded: Vec<(&str, &str)> = report["written"].as_array().unwrap().iter().map(|w| (w["file"].as_str().unwrap(), w["output"].as_str().unwrap())).collect();
        assert_eq!(recorded, [("wing.msh", "wing.msh"), ("wing.mesh", "wing.mesh"), ("wing.vtu", "wing.mesh")]);
    }

    #[test]
    fn an_input_is_never_replaced_nor_removed() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        write(out, &["x.msh", "x.png"], "x.msh").unwrap();
        // the earlier output is now the input of a run of the same output
        let inputs = vec![(out.join("x.msh"), "the input mesh".to_string())];
        let (files, report) = set(&["x.png"]);
        write_set(out, &files, "report.json", report, &Claim { inputs: inputs.clone(), ..claim("x.msh") }).unwrap();
        assert_eq!(names(out), ["report.json", "x.msh", "x.png"]);
        let (files, report) = set(&["x.msh"]);
        let e = write_set(out, &files, "report.json", report, &Claim { inputs, force: true, ..claim("x.msh") }).unwrap_err();
        assert!(matches!(e, FolderError::IsInput { .. }) && e.to_string().contains("the input mesh"), "{e}");
    }

    #[test]
    fn a_foreign_file_or_report_is_refused_unless_forced() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        fs::write(out.join("c.msh"), "theirs").unwrap();
        let e = write(out, &["c.msh"], "c.msh").unwrap_err().to_string();
        assert!(e.contains("c.msh") && e.contains("no report `report.json` records it") && e.contains("--force"), "{e}");
        fs::remove_file(out.join("c.msh")).unwrap();
        fs::write(out.join("report.json"), "not json").unwrap();
        let e = write(out, &["c.msh"], "c.msh").unwrap_err().to_string();
        assert!(e.contains("report.json") && e.contains("is not a report of deformesh"), "{e}");
        assert_eq!(names(out), ["report.json"]);
        check_set(out, &["c.msh".into()], "report.json", &claim("c.msh")).unwrap();
    }

    #[test]
    fn a_report_without_records_makes_its_files_unknown() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        fs::write(out.join("mesh.msh"), "old").unwrap();
        fs::write(out.join("frame.png"), "old").unwrap();
        fs::write(out.join("report.json"), r#"{"outputs": ["mesh.msh", "frame.png", "report.json"]}"#).unwrap();
        check_run_folder(out, "report.json", false).unwrap();
        let e = write(out, &["mesh.msh"], "mesh.msh").unwrap_err().to_string();
        assert!(e.contains("mesh.msh") && e.contains("from a version that recorded no sizes and hashes"), "{e}");
        let (files, report) = set(&["mesh.msh"]);
        write_set(out, &files, "report.json", report, &Claim { force: true, ..claim("mesh.msh") }).unwrap();
        // forced over, and the old frame kept: nothing says it is ours
        assert_eq!(names(out), ["frame.png", "mesh.msh", "report.json"]);
        write(out, &["mesh.msh"], "mesh.msh").unwrap();
    }

    #[test]
    fn a_doctored_report_cannot_delete_outside_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        fs::create_dir(&out).unwrap();
        fs::write(dir.path().join("precious"), "x").unwrap();
        let record = |f: &str| serde_json::to_value(Written::of(f, "mesh.msh", b"x")).unwrap();
        let doctored = serde_json::json!({ "outputs": [], "written": [record("../precious"), record("/etc/passwd"), record(".hidden")] });
        fs::write(out.join("report.json"), doctored.to_string()).unwrap();
        write(&out, &["mesh.msh"], "mesh.msh").unwrap();
        assert!(dir.path().join("precious").exists());
    }

    #[test]
    fn a_folder_of_someone_else_is_refused_and_a_file_is_no_folder() {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join("data.csv"), "1,2").unwrap();
        let e = check_run_folder(dir.path(), "report.json", false).unwrap_err().to_string();
        assert!(e.contains("not empty") && e.contains("data.csv"), "{e}");
        check_run_folder(dir.path(), "report.json", true).unwrap();
        let file = dir.path().join("data.csv");
        let e = check_run_folder(&file, "report.json", false).unwrap_err().to_string();
        assert!(e.contains("data.csv") && e.contains("is a file"), "{e}");
        let e = check_run_folder(&file.join("sub"), "report.json", false).unwrap_err().to_string();
        assert!(e.contains("is a file"), "{e}");
        let e = check_output_file(dir.path()).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        check_output_file(&dir.path().join("new/curved.msh")).unwrap();
        assert!(!dir.path().join("new").exists(), "a check creates nothing");
    }

    #[test]
    fn a_failed_write_leaves_no_staged_file_nor_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        // a folder where report.json should go: refused before staging
        let out = dir.path().join("out");
        fs::create_dir_all(out.join("report.json")).unwrap();
        fs::write(out.join("report.json").join("x"), "x").unwrap();
        let e = write(&out, &["mesh.msh", "mesh.vtu"], "mesh.msh").unwrap_err();
        assert!(e.to_string().contains("report.json") && !e.is_write_failure(), "{e}");
        assert_eq!(names(&out), ["report.json"], "nothing staged or half renamed is left");
        // a new folder whose write fails is removed again, and the failure
        // is the file system's
        let fresh = dir.path().join("fresh");
        let bad = vec![("sub/mesh.msh".to_string(), vec![1u8])];
        let e = write_set(&fresh, &bad, "report.json", serde_json::json!({ "outputs": [] }), &claim("mesh.msh")).unwrap_err();
        assert!(e.is_write_failure(), "{e}");
        assert!(!fresh.exists());
    }
}
