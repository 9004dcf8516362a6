//! A run's output files written into a folder as one set.
//!
//! Two runs into one folder must never mix their files, a rerun must not
//! leave an earlier run's frames beside its own, and neither a failed write
//! nor Ctrl-C may leave staged files behind. So the folder is locked while a
//! set is written (`flock` on the folder itself: no lock file that could go
//! stale); every file is first staged under a hidden name, then all are
//! renamed into place, then what the earlier run's report listed and this
//! run did not write is removed. Whether the folder can take the files is
//! checked before any computing ([`check_run_folder`], [`check_output_file`]).

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
    #[error("output folder `{}` is not empty (it holds `{found}`) and has no {report} of an earlier run: choose a new or empty folder", folder.display())]
    NotOurs {
        /// The folder.
        folder: PathBuf,
        /// One file found in it.
        found: String,
        /// The report that marks a folder written by this tool.
        report: String,
    },
    /// Reading, writing, renaming or locking failed.
    #[error("cannot write `{}`", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
}

fn io_at(path: &Path) -> impl FnOnce(io::Error) -> FolderError + '_ {
    move |source| FolderError::Io { path: path.to_path_buf(), source }
}

/// Checks, before any computing, that the folder `dir` can take a run's
/// outputs: it is a folder (or can be made one), writable, and either
/// empty or written earlier by this tool (it holds `report`).
pub fn check_run_folder(dir: &Path, report: &str) -> Result<(), FolderError> {
    if dir.is_dir() {
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
    if previous_outputs(dir, report).is_some() {
        return Ok(());
    }
    let names = fs::read_dir(dir).map_err(io_at(dir))?;
    let found = names.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).find(|n| !is_staged(n));
    match found {
        None => Ok(()),
        Some(found) => Err(FolderError::NotOurs { folder: dir.to_path_buf(), found, report: report.to_string() }),
    }
}

/// The files an earlier run's `report` (JSON with an `outputs` list) says
/// it wrote; only plain visible names, so a doctored report cannot make a
/// rerun delete anything outside the folder.
fn previous_outputs(dir: &Path, report: &str) -> Option<Vec<String>> {
    let text = fs::read_to_string(dir.join(report)).ok()?;
    let value: serde_json::Value = serde_json::from_str(&text).ok()?;
    let names = value.get("outputs")?.as_array()?;
    let plain = |n: &&str| !n.is_empty() && !n.starts_with('.') && !n.contains(['/', '\\']);
    Some(names.iter().filter_map(|n| n.as_str()).filter(plain).map(str::to_string).collect())
}

/// Names of staged files: `.<name>.staged-<pid>`.
fn is_staged(name: &str) -> bool {
    name.starts_with('.') && name.contains(".staged-")
}

/// Writes `files` (name, bytes) into `dir` as one set, creating `dir` if
/// needed: locked against other runs, staged, renamed into place, then
/// the files of the earlier run (listed in its `report`) that this set does
/// not replace are removed. On failure nothing staged is left, nor a folder
/// this call created.
pub fn write_set(dir: &Path, files: &[(String, Vec<u8>)], report: &str) -> Result<(), FolderError> {
    // dropped last: a Ctrl-C during the write takes effect after the cleanup
    let _writing = Writing::begin();
    let created = !dir.exists();
    fs::create_dir_all(dir).map_err(io_at(dir))?;
    let result = locked_write(dir, files, report);
    if result.is_err() && created {
        let _ = fs::remove_dir(dir);
    }
    result
}

fn locked_write(dir: &Path, files: &[(String, Vec<u8>)], report: &str) -> Result<(), FolderError> {
    let _lock = lock(dir)?;
    interrupted(dir)?;
    // under the lock, staged files are leftovers of a killed run
    for e in fs::read_dir(dir).map_err(io_at(dir))?.filter_map(|e| e.ok()) {
        if is_staged(&e.file_name().to_string_lossy()) {
            let _ = fs::remove_file(e.path());
        }
    }
    let previous = previous_outputs(dir, report).unwrap_or_default();
    let mut staged = Staged(Vec::new());
    for (name, bytes) in files {
        let tmp = dir.join(format!(".{name}.staged-{}", std::process::id()));
        staged.0.push((tmp.clone(), dir.join(name)));
        write_and_sync(&tmp, bytes).map_err(io_at(&tmp))?;
        pause_for_tests();
        interrupted(dir)?;
    }
    for (_, path) in &staged.0 {
        if fs::symlink_metadata(path).is_ok_and(|m| m.is_dir()) {
            return Err(FolderError::Io { path: path.clone(), source: io::Error::new(io::ErrorKind::IsADirectory, "a folder of that name is in the way") });
        }
    }
    while let Some((tmp, path)) = staged.0.first().cloned() {
        fs::rename(&tmp, &path).map_err(io_at(&path))?;
        staged.0.remove(0);
        pause_for_tests();
    }
    for name in previous.iter().filter(|n| !files.iter().any(|f| &f.0 == *n)) {
        let path = dir.join(name);
        if fs::symlink_metadata(&path).is_ok_and(|m| m.is_file()) {
            fs::remove_file(&path).map_err(io_at(&path))?;
        }
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
/// had been installed (the shell then sees the usual status).
fn die(sig: i32) {
    #[cfg(unix)]
    // SAFETY: async-signal-safe calls only.
    unsafe {
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

    fn set(names: &[&str]) -> Vec<(String, Vec<u8>)> {
        let outputs: Vec<&str> = names.iter().copied().chain(["report.json"]).collect();
        let report = serde_json::json!({ "outputs": outputs }).to_string();
        names.iter().map(|n| (n.to_string(), n.as_bytes().to_vec())).chain([("report.json".to_string(), report.into_bytes())]).collect()
    }

    #[test]
    fn a_rerun_removes_the_earlier_runs_files_only() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        write_set(&out, &set(&["mesh.msh", "frame_t0.30.png", "deformation.gif"]), "report.json").unwrap();
        fs::write(out.join("notes.txt"), "mine").unwrap();
        check_run_folder(&out, "report.json").unwrap();
        write_set(&out, &set(&["mesh.msh"]), "report.json").unwrap();
        assert_eq!(names(&out), ["mesh.msh", "notes.txt", "report.json"]);
    }

    #[test]
    fn a_doctored_report_cannot_delete_outside_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        fs::create_dir(&out).unwrap();
        fs::write(dir.path().join("precious"), "x").unwrap();
        fs::write(out.join("report.json"), r#"{"outputs": ["../precious", "/etc/passwd", ".hidden"]}"#).unwrap();
        write_set(&out, &set(&["mesh.msh"]), "report.json").unwrap();
        assert!(dir.path().join("precious").exists());
    }

    #[test]
    fn a_folder_of_someone_else_is_refused_and_a_file_is_no_folder() {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join("data.csv"), "1,2").unwrap();
        let e = check_run_folder(dir.path(), "report.json").unwrap_err().to_string();
        assert!(e.contains("not empty") && e.contains("data.csv"), "{e}");
        let file = dir.path().join("data.csv");
        let e = check_run_folder(&file, "report.json").unwrap_err().to_string();
        assert!(e.contains("data.csv") && e.contains("is a file"), "{e}");
        let e = check_run_folder(&file.join("sub"), "report.json").unwrap_err().to_string();
        assert!(e.contains("is a file"), "{e}");
        let e = check_output_file(dir.path()).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        check_output_file(&dir.path().join("new/curved.msh")).unwrap();
        assert!(!dir.path().join("new").exists(), "a check creates nothing");
    }

    #[test]
    fn a_failed_write_leaves_no_staged_file_nor_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        // a folder where report.json should go: the renames would fail
        let out = dir.path().join("out");
        fs::create_dir_all(out.join("report.json")).unwrap();
        fs::write(out.join("report.json").join("x"), "x").unwrap();
        let e = write_set(&out, &set(&["mesh.msh", "mesh.vtu"]), "report.json").unwrap_err();
        assert!(e.to_string().contains("report.json"), "{e}");
        assert_eq!(names(&out), ["report.json"], "nothing staged or half renamed is left");
        // a new folder whose write fails is removed again
        let fresh = dir.path().join("fresh");
        let bad = vec![("sub/mesh.msh".to_string(), vec![1u8])];
        assert!(write_set(&fresh, &bad, "report.json").is_err());
        assert!(!fresh.exists());
    }
}
