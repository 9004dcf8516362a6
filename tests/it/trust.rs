//! Issue 43: no run deletes or replaces a user's file, a failed write or
//! too little memory is a message with its own exit code, and refusals of
//! a mesh's structure name the file's own tags. The real binary runs on
//! small meshes made in each test; every test checks the exit code and
//! what is on disk afterwards.

use std::path::{Path, PathBuf};
use std::process::Command;
use tempfile::TempDir;

use crate::common::WALL_CIRCLE as WALL;

/// What a run of the binary gave.
struct Ran {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// Runs `deformesh ARGS` inside `dir`.
fn deformesh(dir: &Path, args: &[&str]) -> Ran {
    let out = Command::new(env!("CARGO_BIN_EXE_deformesh")).args(args).current_dir(dir).env_remove("RUST_LOG").output().expect("cannot start deformesh");
    Ran { code: out.status.code(), stdout: String::from_utf8_lossy(&out.stdout).into_owned(), stderr: String::from_utf8_lossy(&out.stderr).into_owned() }
}

/// Sorted names of everything in `dir`, hidden files included.
fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

fn cylinder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cylinder_bl_coarse.msh")
}

/// A folder with the linear cylinder mesh `in.msh` and its geometry file
/// `geo.toml` (curving it at order 2 takes a tenth of a second).
fn cylinder_folder() -> TempDir {
    let dir = TempDir::new().unwrap();
    std::fs::copy(cylinder(), dir.path().join("in.msh")).unwrap();
    std::fs::write(dir.path().join("geo.toml"), WALL).unwrap();
    dir
}

/// `deformesh curve IN --geometry geo.toml --order 2 -o OUT EXTRA...` in `dir`.
fn curve(dir: &Path, input: &str, out: &str, extra: &[&str]) -> Ran {
    let mut args = vec!["curve", input, "--geometry", "geo.toml", "--order", "2", "-o", out];
    args.extend_from_slice(extra);
    deformesh(dir, &args)
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn ok(ran: &Ran, what: &str) {
    assert_eq!(ran.code, Some(0), "{what}: {}", ran.stderr);
}

// ------------------------------------------------------------ outputs

#[test]
fn a_rerun_in_another_format_keeps_the_first_output_byte_for_byte() {
    let dir = cylinder_folder();
    let d = dir.path().join("d");
    ok(&curve(dir.path(), "in.msh", "d/wing.msh", &[]), "first run");
    let msh = read(&d.join("wing.msh"));
    ok(&curve(dir.path(), "in.msh", "d/wing.mesh", &[]), "MFEM rerun");
    assert_eq!(files_in(&d), ["wing.mesh", "wing.msh", "wing.png", "wing.report.json", "wing.vtu"]);
    assert_eq!(read(&d.join("wing.msh")), msh, "the MSH output of the first run is untouched");
    // the first output is still recorded as ours: writing it again needs
    // no --force, and keeps the MFEM file
    let mesh = read(&d.join("wing.mesh"));
    ok(&deformesh(dir.path(), &["curve", "in.msh", "--geometry", "geo.toml", "--order", "3", "-o", "d/wing.msh"]), "MSH rerun");
    assert_eq!(files_in(&d), ["wing.mesh", "wing.msh", "wing.png", "wing.report.json", "wing.vtu"]);
    assert_eq!(read(&d.join("wing.mesh")), mesh);
    assert_ne!(read(&d.join("wing.msh")), msh, "order 3 replaced the order-2 file");
}

#[test]
fn a_rerun_never_deletes_its_input() {
    let dir = cylinder_folder();
    let e = dir.path().join("e");
    ok(&curve(dir.path(), "in.msh", "e/x.msh", &[]), "first run");
    // a new linear mesh where the curved one was, curved into another format
    std::fs::copy(cylinder(), e.join("x.msh")).unwrap();
    let ran = curve(dir.path(), "e/x.msh", "e/x.inp", &[]);
    ok(&ran, "ABAQUS run from e/x.msh");
    assert_eq!(read(&e.join("x.msh")), read(&cylinder()), "the input is there byte for byte");
    assert_eq!(files_in(&e), ["x.inp", "x.msh", "x.png", "x.report.json", "x.vtu"]);
    // and a rerun of the input's own output name is refused as the input
    let ran = curve(dir.path(), "e/x.msh", "e/x.msh", &["--force"]);
    assert_eq!(ran.code, Some(64), "{}", ran.stderr);
    assert!(ran.stderr.contains("is the input mesh"), "{}", ran.stderr);
    assert_eq!(read(&e.join("x.msh")), read(&cylinder()));
    // an input among the siblings: the geometry file named as the picture
    std::fs::copy(dir.path().join("geo.toml"), dir.path().join("g.png")).unwrap();
    let ran = deformesh(dir.path(), &["curve", "in.msh", "--geometry", "g.png", "--order", "2", "-o", "g.msh", "--force"]);
    assert_eq!(ran.code, Some(64), "{}", ran.stderr);
    assert!(ran.stderr.contains("g.png") && ran.stderr.contains("is an input of this run (the geometry file)"), "{}", ran.stderr);
    assert_eq!(read(&dir.path().join("g.png")), WALL.as_bytes());
    assert!(!dir.path().join("g.msh").exists());
}

#[test]
fn an_existing_file_no_run_wrote_is_refused_unless_forced() {
    let dir = cylinder_folder();
    let p = dir.path();
    // the output itself, then a sibling, each a user's file
    for (theirs, out) in [("f.msh", "f.msh"), ("g.png", "g.msh"), ("h.report.json", "h.msh"), ("k.vtu", "k.inp")] {
        std::fs::write(p.join(theirs), "a user's file").unwrap();
        let ran = curve(p, "in.msh", out, &[]);
        assert_eq!(ran.code, Some(73), "{out}: {}", ran.stderr);
        assert!(ran.stderr.contains(&format!("{theirs}` exists and")) && ran.stderr.contains("--force"), "{}", ran.stderr);
        assert!(!ran.stderr.contains("algorithm 2"), "refused before computing: {}", ran.stderr);
        assert_eq!(read(&p.join(theirs)), b"a user's file");
        let stem = format!("{}.", out.split('.').next().unwrap());
        assert_eq!(files_in(p).iter().filter(|f| f.starts_with(&stem)).collect::<Vec<_>>(), [theirs], "nothing written beside it");
    }
    // --force replaces it
    ok(&curve(p, "in.msh", "f.msh", &["--force"]), "forced");
    assert!(read(&p.join("f.msh")).starts_with(b"$MeshFormat"));
    // an output of ours changed since: no longer ours
    ok(&curve(p, "in.msh", "c.msh", &[]), "first run");
    let mut vtu = read(&p.join("c.vtu"));
    vtu[100] ^= 1;
    std::fs::write(p.join("c.vtu"), &vtu).unwrap();
    let ran = curve(p, "in.msh", "c.msh", &[]);
    assert_eq!(ran.code, Some(73), "{}", ran.stderr);
    assert!(ran.stderr.contains("c.vtu` exists and changed since deformesh wrote it"), "{}", ran.stderr);
    assert_eq!(read(&p.join("c.vtu")), vtu);
}

#[test]
fn a_run_folder_keeps_a_file_changed_since_and_refuses_to_replace_it() {
    let dir = TempDir::new().unwrap();
    let p = dir.path();
    let case = "name = \"small\"\n[mesh]\nlower = [0.0, 0.0]\nupper = [1.0, 1.0]\ncells = [4, 4]\n\n[[boundary]]\nname = \"axes\"\nsides = [\"left\", \"bottom\"]\nkind = \"slip\"\n\n[[boundary]]\nname = \"arc\"\nsides = [\"right\", \"top\"]\nkind = \"move\"\nshape = { type = \"circle\", centre = [0.0, 0.0], radius = 1.25 }\ncorrespondence = \"radial\"\ncentre = [0.0, 0.0]\n\n[time]\nsteps = 4\n";
    std::fs::write(p.join("frames.toml"), format!("{case}\n[output]\nframes = [0.0, 1.0]\n")).unwrap();
    std::fs::write(p.join("plain.toml"), case).unwrap();
    ok(&deformesh(p, &["run", "frames.toml", "-o", "out"]), "with frames");
    let out = p.join("out");
    std::fs::write(out.join("frame_t0.00.png"), "annotated by hand").unwrap();
    ok(&deformesh(p, &["run", "plain.toml", "-o", "out"]), "without frames");
    // the unchanged frame was the earlier run's and went; the changed one stays
    assert_eq!(files_in(&out), ["frame_t0.00.png", "mesh.msh", "mesh.png", "mesh.vtu", "report.json"]);
    assert_eq!(read(&out.join("frame_t0.00.png")), b"annotated by hand");
    // writing it again is refused, and forced it is replaced
    let ran = deformesh(p, &["run", "frames.toml", "-o", "out"]);
    assert_eq!(ran.code, Some(73), "{}", ran.stderr);
    assert!(ran.stderr.contains("frame_t0.00.png` exists and was not written by deformesh"), "{}", ran.stderr);
    assert_eq!(read(&out.join("frame_t0.00.png")), b"annotated by hand");
    ok(&deformesh(p, &["run", "frames.toml", "-o", "out", "--force"]), "forced");
    assert!(read(&out.join("frame_t0.00.png")).starts_with(b"\x89PNG"));
}

#[cfg(unix)]
#[test]
fn a_write_that_fails_has_its_own_exit_code_and_leaves_nothing() {
    let dir = cylinder_folder();
    let p = dir.path();
    // a file size limit of 16 kB: the MSH file (85 kB) cannot be written
    // (EFBIG, as a full disk gives ENOSPC)
    let script = format!("trap '' XFSZ; ulimit -f 32; exec '{}' curve in.msh --geometry geo.toml --order 2 -o d/w.msh", env!("CARGO_BIN_EXE_deformesh"));
    let out = Command::new("sh").args(["-c", &script]).current_dir(p).env_remove("RUST_LOG").output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(74), "{stderr}");
    assert!(stderr.contains("writing `d/w.msh` failed; nothing was written") && stderr.contains("too large"), "{stderr}");
    assert!(!p.join("d").exists(), "the folder this run made is gone");
    assert_eq!(files_in(p), ["geo.toml", "in.msh"]);
}

// ------------------------------------------------------------ the file's own tags

/// An ASCII MSH 4.1 plane mesh: `nodes` (tag, x, y) on one surface,
/// `lines` (tag, node tags) on curve 1 in the group `wall`, `cells`
/// (tag, node tags; 4 nodes a quad, 3 a triangle) on surface 1.
fn msh2d(nodes: &[(u64, f64, f64)], cells: &[(u64, &[u64])], lines: &[(u64, &[u64])]) -> String {
    let tags: Vec<u64> = nodes.iter().map(|n| n.0).collect();
    let mut s = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n1 1 \"wall\"\n$EndPhysicalNames\n");
    s += "$Entities\n0 1 1 0\n1 0 0 0 2 2 0 1 1 0\n1 0 0 0 2 2 0 0 1 1\n$EndEntities\n";
    s += &format!("$Nodes\n1 {} {} {}\n2 1 0 {}\n", nodes.len(), tags.iter().min().unwrap(), tags.iter().max().unwrap(), nodes.len());
    for n in nodes {
        s += &format!("{}\n", n.0);
    }
    for n in nodes {
        s += &format!("{} {} 0\n", n.1, n.2);
    }
    s += "$EndNodes\n";
    let all: Vec<u64> = cells.iter().chain(lines).map(|e| e.0).collect();
    let blocks = [(1, 1, 1, lines), (2, 1, if cells.first().is_some_and(|c| c.1.len() == 3) { 2 } else { 3 }, cells)];
    let blocks: Vec<_> = blocks.iter().filter(|b| !b.3.is_empty()).collect();
    s += &format!("$Elements\n{} {} {} {}\n", blocks.len(), all.len(), all.iter().min().unwrap(), all.iter().max().unwrap());
    for (dim, entity, ty, elements) in blocks {
        s += &format!("{dim} {entity} {ty} {}\n", elements.len());
        for (tag, n) in elements.iter() {
            s += &format!("{tag} {}\n", n.iter().map(u64::to_string).collect::<Vec<_>>().join(" "));
        }
    }
    s + "$EndElements\n"
}

/// The geometry file that holds the group `wall` fixed.
const FIXED: &str = "[[group]]\nname = \"wall\"\nkind = \"fixed\"\n";

/// Runs `quality` (if `quality`) and `curve` on the mesh `text` written as
/// `name`: each must exit 1, name the file and say every one of `needles`,
/// and write nothing.
fn refused(name: &str, text: &str, quality: bool, needles: &[&str]) -> String {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join(name), text).unwrap();
    std::fs::write(dir.path().join("geo.toml"), FIXED).unwrap();
    let mut runs = vec![vec!["curve", name, "--geometry", "geo.toml", "--order", "2", "-o", "out/c.msh"]];
    if quality {
        runs.push(vec!["quality", name]);
    }
    let mut said = String::new();
    for args in runs {
        let ran = deformesh(dir.path(), &args);
        assert_eq!(ran.code, Some(1), "{args:?}: {}", ran.stderr);
        assert!(ran.stderr.contains(name) && !ran.stderr.contains("panicked"), "{}", ran.stderr);
        for needle in needles {
            assert!(ran.stderr.contains(needle), "{args:?}: stderr lacks `{needle}`:\n{}", ran.stderr);
        }
        assert_eq!(ran.stdout, "", "{args:?}");
        said = ran.stderr;
    }
    let mut inputs = vec!["geo.toml", name];
    inputs.sort();
    assert_eq!(files_in(dir.path()), inputs, "nothing written");
    said
}

/// The unit square's four corners with tags from 1000.
fn square_from_1000() -> Vec<(u64, f64, f64)> {
    vec![(1000, 0.0, 0.0), (2113, 1.0, 0.0), (3457, 1.0, 1.0), (1001, 0.0, 1.0)]
}

#[test]
fn a_file_with_no_cells_is_bad_input_for_quality_and_curve() {
    // the boundary of the unit square only, node tags from 1000
    let text = msh2d(&square_from_1000(), &[], &[(1, &[1000, 2113]), (2, &[2113, 3457]), (3, &[3457, 1001]), (4, &[1001, 1000])]);
    let said = refused("outline.msh", &text, true, &["no cells (the file holds 4 lines)", "a mesh of the domain is expected"]);
    assert!(!said.contains("inf"), "{said}");
}

#[test]
fn duplicate_element_and_node_tags_are_refused_naming_them() {
    let nodes: Vec<(u64, f64, f64)> = vec![(1, 0.0, 0.0), (2, 1.0, 0.0), (3, 2.0, 0.0), (4, 0.0, 1.0), (5, 1.0, 1.0), (6, 2.0, 1.0)];
    let lines: [(u64, &[u64]); 6] = [(1, &[1, 2]), (2, &[2, 3]), (3, &[3, 6]), (4, &[6, 5]), (5, &[5, 4]), (6, &[4, 1])];
    let text = msh2d(&nodes, &[(101, &[1, 2, 5, 4]), (101, &[2, 3, 6, 5])], &lines);
    refused("twice.msh", &text, true, &["element tag 101 is used twice", "nodes 1 2 5 4", "nodes 2 3 6 5", "both in the element block at line 38"]);
    // a boundary element and a cell with one tag
    let text = msh2d(&nodes, &[(6, &[1, 2, 5, 4]), (7, &[2, 3, 6, 5])], &lines);
    refused("shared.msh", &text, true, &["element tag 6 is used twice", "nodes 4 1", "nodes 1 2 5 4", "in the element blocks at line 31 and line 38"]);
    // node tag 5 given twice (the second at (2, 1))
    let mut twice = nodes.clone();
    twice[5].0 = 5;
    let text = msh2d(&twice, &[(101, &[1, 2, 5, 4]), (102, &[2, 3, 6, 5])], &lines);
    refused("nodes.msh", &text, true, &["line 21: node tag 5 is defined twice"]);
}

#[test]
fn structure_refusals_name_the_files_tags_and_the_real_cause() {
    // a hanging node: the tall quad 101 beside quads 102 and 103, whose
    // common corner 7 is on 101's edge 2-5
    let nodes = [(1, 0.0, 0.0), (2, 1.0, 0.0), (3, 2.0, 0.0), (4, 0.0, 2.0), (5, 1.0, 2.0), (6, 2.0, 2.0), (7, 1.0, 1.0), (8, 2.0, 1.0)];
    let cells: [(u64, &[u64]); 3] = [(101, &[1, 2, 5, 4]), (102, &[2, 3, 8, 7]), (103, &[7, 8, 6, 5])];
    let lines: [(u64, &[u64]); 7] = [(1, &[1, 2]), (2, &[2, 3]), (3, &[3, 8]), (4, &[8, 6]), (5, &[6, 5]), (6, &[5, 4]), (7, &[4, 1])];
    let said = refused("hanging.msh", &msh2d(&nodes, &cells, &lines), false, &["node 7 is a hanging node", "edge with nodes 2 5 of element 101", "a corner of elements 102, 103", "not conforming"]);
    assert!(!said.contains("SaveAll"), "{said}");
    // duplicate nodes: quad 102 uses 9 and 10, copies of 2 and 5
    let nodes = [(1, 0.0, 0.0), (2, 1.0, 0.0), (3, 2.0, 0.0), (4, 0.0, 1.0), (5, 1.0, 1.0), (6, 2.0, 1.0), (9, 1.0, 0.0), (10, 1.0, 1.0)];
    let lines: [(u64, &[u64]); 6] = [(1, &[1, 2]), (2, &[9, 3]), (3, &[3, 6]), (4, &[6, 10]), (5, &[5, 4]), (6, &[4, 1])];
    let said = refused("cut.msh", &msh2d(&nodes, &[(101, &[1, 2, 5, 4]), (102, &[9, 3, 6, 10])], &lines), false, &["nodes 2 and 9 are at the same place (1, 0, 0) (2 pairs in all)", "merge the duplicate nodes"]);
    assert!(!said.contains("SaveAll"), "{said}");
    // tags from 1000: a boundary line across the square's diagonal
    let square = square_from_1000();
    let outline: Vec<(u64, &[u64])> = vec![(1, &[1000, 2113]), (2, &[2113, 3457]), (3, &[3457, 1001]), (4, &[1001, 1000])];
    let cell: [(u64, &[u64]); 1] = [(5, &[1000, 2113, 3457, 1001])];
    let diagonal: Vec<(u64, &[u64])> = outline.iter().cloned().chain([(9, &[2113, 1001][..])]).collect();
    refused("diagonal.msh", &msh2d(&square, &cell, &diagonal), false, &["boundary element 9 (nodes 2113 1001) is not an edge of any cell"]);
    // an edge with no boundary element: named by its cell and nodes
    refused("open.msh", &msh2d(&square, &cell, &outline[..3]), false, &["1 edge(s) on the boundary of the mesh are in no boundary element (the first: the edge of element 5 with nodes 1001 1000)", "Mesh.SaveAll"]);
    // a boundary line between two cells
    let nodes = [(11, 0.0, 0.0), (12, 1.0, 0.0), (13, 2.0, 0.0), (14, 0.0, 1.0), (15, 1.0, 1.0), (16, 2.0, 1.0)];
    let lines: [(u64, &[u64]); 7] = [(1, &[11, 12]), (2, &[12, 13]), (3, &[13, 16]), (4, &[16, 15]), (5, &[15, 14]), (6, &[14, 11]), (7, &[12, 15])];
    refused("inside.msh", &msh2d(&nodes, &[(21, &[11, 12, 15, 14]), (22, &[12, 13, 16, 15])], &lines), false, &["boundary element 7 (nodes 12 15) lies inside the mesh, between elements 21 and 22"]);
}

// ------------------------------------------------------------ memory

/// A folder with an n×n quad box `box.msh` (its side `top` held fixed by
/// `geo.toml`, the other sides unbound).
fn box_folder(n: usize) -> TempDir {
    let dir = TempDir::new().unwrap();
    let text = deformesh::io::msh::msh_string(&deformesh::mesh::QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], n, n));
    std::fs::write(dir.path().join("box.msh"), text).unwrap();
    std::fs::write(dir.path().join("geo.toml"), "[[group]]\nname = \"top\"\nkind = \"fixed\"\n").unwrap();
    dir
}

/// `deformesh curve box.msh ... --order P ARGS -o d/b.msh` under an
/// address-space limit of `limit_mib`.
fn curve_limited(dir: &Path, limit_mib: u64, order: usize, args: &str) -> (Option<i32>, String, std::time::Duration) {
    let script = format!("ulimit -v {}; exec '{}' curve box.msh --geometry geo.toml --order {order} {args} -o d/b.msh", limit_mib * 1024, env!("CARGO_BIN_EXE_deformesh"));
    let start = std::time::Instant::now();
    let out = Command::new("sh").args(["-c", &script]).current_dir(dir).env_remove("RUST_LOG").output().unwrap();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned(), start.elapsed())
}

#[cfg(target_os = "linux")]
#[test]
fn a_run_whose_estimate_exceeds_the_memory_limit_is_refused_at_once() {
    let dir = box_folder(100);
    let (code, stderr, took) = curve_limited(dir.path(), 400, 4, "--band all");
    assert_eq!(code, Some(4), "{stderr}");
    for needle in ["this run needs about", "estimated for 163216 nodes of order 4 in 2D, --band all", "the address-space limit (RLIMIT_AS, `ulimit -v`) of 400 MiB", "nothing was computed or written", "At --order 3 it needs about"] {
        assert!(stderr.contains(needle), "stderr lacks `{needle}`:\n{stderr}");
    }
    assert!(took.as_secs_f64() < 5.0, "refused after {took:?}");
    assert_eq!(files_in(dir.path()), ["box.msh", "geo.toml"], "nothing written");
    // the order it advises fits under the same limit, and runs
    let (code, stderr, _) = curve_limited(dir.path(), 400, 3, "--band all");
    assert_eq!(code, Some(0), "{stderr}");
    assert!(dir.path().join("d/b.msh").exists());
}

#[cfg(target_os = "linux")]
#[test]
fn an_allocation_that_fails_is_a_message_and_exit_code_4_not_an_abort() {
    // the benchmark's 5000² cells need far more than 400 MiB, and it
    // estimates nothing: its first large allocation fails
    let dir = TempDir::new().unwrap();
    let script = format!("ulimit -v {}; exec '{}' bench --sizes 5000 --repeat 1", 400 * 1024, env!("CARGO_BIN_EXE_deformesh"));
    let out = Command::new("sh").args(["-c", &script]).current_dir(dir.path()).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(4), "{stderr}");
    assert!(stderr.contains("error: out of memory: an allocation of") && stderr.contains("failed under the address-space limit (RLIMIT_AS, `ulimit -v`) of 400 MiB; nothing was written"), "{stderr}");
    assert_eq!(files_in(dir.path()), Vec::<String>::new());
}

// ------------------------------------------------------------ small items

#[test]
fn an_upper_case_output_a_compressed_input_and_mixed_orders_are_said_clearly() {
    let dir = cylinder_folder();
    let p = dir.path();
    // `.MSH` is MSH 4.1, as `.msh`
    let ran = curve(p, "in.msh", "UP.MSH", &[]);
    ok(&ran, "-o UP.MSH");
    assert!(read(&p.join("UP.MSH")).starts_with(b"$MeshFormat\n4.1"));
    // a gzip file is named as one
    let mut gz = vec![0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3];
    gz.extend_from_slice(&[0u8; 20]);
    std::fs::write(p.join("in.msh.gz"), &gz).unwrap();
    for args in [vec!["quality", "in.msh.gz"], vec!["curve", "in.msh.gz", "--geometry", "geo.toml", "-o", "gz.msh"]] {
        let ran = deformesh(p, &args);
        assert_eq!(ran.code, Some(1), "{}", ran.stderr);
        assert!(ran.stderr.contains("in.msh.gz: the file is gzip-compressed, not an MSH file: decompress it first (e.g. `gunzip FILE`)"), "{}", ran.stderr);
    }
    // linear quads bounded by lines of order 2: one order per mesh, said so
    let mixed = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 5 1 5\n2 1 0 5\n1\n2\n3\n4\n5\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0 0\n$EndNodes\n$Elements\n2 2 1 2\n2 1 3 1\n1 1 2 3 4\n1 1 8 1\n2 1 2 5\n$EndElements\n";
    std::fs::write(p.join("mixed.msh"), mixed).unwrap();
    let ran = deformesh(p, &["quality", "mixed.msh"]);
    assert_eq!(ran.code, Some(1), "{}", ran.stderr);
    assert!(ran.stderr.contains("mixed.msh: line 22: an element block of order 2 in a mesh whose first cell is of order 1"), "{}", ran.stderr);
    assert!(!ran.stderr.contains("only linear meshes"), "{}", ran.stderr);
}

#[test]
fn cad_models_are_named_read_whatever_the_case_of_their_extension_and_an_empty_library_path_is_said() {
    let dir = TempDir::new().unwrap();
    let p = dir.path();
    let (step, mesh) = (p.join("disk.step"), p.join("disk.msh"));
    crate::common::run_script("cad_primitives.py", &[std::ffi::OsStr::new("disk"), step.as_os_str(), mesh.as_os_str()]);
    let lib = crate::common::gmsh_lib();
    let with_lib = |lib: &std::ffi::OsStr, model: &str, out: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_deformesh")).args(["curve", "disk.msh", "--cad", model, "--order", "2", "-o", out]).current_dir(p).env("DEFORMESH_GMSH_LIB", lib).env_remove("RUST_LOG").output().unwrap();
        Ran { code: out.status.code(), stdout: String::from_utf8_lossy(&out.stdout).into_owned(), stderr: String::from_utf8_lossy(&out.stderr).into_owned() }
    };
    // `.Stp` is read as STEP (Gmsh alone would read it as a .geo script)
    std::fs::copy(&step, p.join("Disk.Stp")).unwrap();
    let ran = with_lib(lib.as_os_str(), "Disk.Stp", "a.msh");
    ok(&ran, "Disk.Stp");
    assert!(!ran.stdout.contains('\x1b'), "terminal codes on stdout:\n{}", ran.stdout);
    // a model Gmsh cannot read: the message starts with the model's file
    std::fs::write(p.join("bad.step"), "ISO-10303-21;\nnot a model\n").unwrap();
    let ran = with_lib(lib.as_os_str(), "bad.step", "b.msh");
    assert_eq!(ran.code, Some(1), "{}", ran.stderr);
    assert!(ran.stderr.contains("\nerror: bad.step: Gmsh's gmshMerge failed") || ran.stderr.starts_with("error: bad.step: Gmsh's gmshMerge failed"), "{}", ran.stderr);
    // OpenCASCADE's diagnostics (with terminal colour codes) go to stderr
    assert_eq!(ran.stdout, "", "stdout is the user's");
    assert!(!p.join("b.msh").exists());
    // an empty DEFORMESH_GMSH_LIB is said as such (it loaded the program itself)
    let ran = with_lib(std::ffi::OsStr::new(""), "disk.step", "c.msh");
    assert_eq!(ran.code, Some(69), "{}", ran.stderr);
    assert!(ran.stderr.contains("DEFORMESH_GMSH_LIB is set but empty") && !ran.stderr.contains("gmshFree"), "{}", ran.stderr);
}

#[cfg(unix)]
#[test]
fn sigterm_and_sigint_are_said_on_stderr_and_leave_nothing() {
    use std::os::unix::process::ExitStatusExt;
    let dir = box_folder(150);
    for sig in [libc::SIGTERM, libc::SIGINT] {
        // about 2 s of work at order 4 without the snap: signalled early
        let child = Command::new(env!("CARGO_BIN_EXE_deformesh"))
            .args(["curve", "box.msh", "--geometry", "geo.toml", "--order", "4", "--snap", "never", "-o", "d/b.msh"])
            .current_dir(dir.path())
            .env_remove("RUST_LOG")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(300));
        // SAFETY: signalling our own child process
        assert_eq!(unsafe { libc::kill(child.id() as i32, sig) }, 0);
        let done = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&done.stderr);
        assert_eq!(done.status.signal(), Some(sig), "{stderr}");
        let name = if sig == libc::SIGTERM { "terminated (SIGTERM)" } else { "interrupted (SIGINT)" };
        assert!(stderr.contains(&format!("deformesh: {name}: the outputs are written whole or not at all")), "{stderr}");
        assert_eq!(files_in(dir.path()), ["box.msh", "geo.toml"], "nothing written");
    }
}
