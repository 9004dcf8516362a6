//! The `deformesh` command line as a library function, so that the
//! binary and the Python package's `deformesh` command are one program:
//! argument handling, the runs' printed figures and progress display. All
//! work is done by the rest of the library.

use crate::app::case::{AnySetup, Case, DEMO_CASE};
use crate::app::driver::{exit, run_any_with, CurveJob, OutputFormat, Progress, RunError, REPORT};
use crate::deform::SolverChoice;
use crate::highorder::curve::{certify_mesh, CurvedQuality};
use crate::io::folder::check_run_folder;
use crate::io::msh::MshError;
use anyhow::Result;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::ffi::OsString;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "deformesh",
    version,
    about = "Curved, boundary-conforming meshes of every element kind (triangles, quads, tetrahedra, hexes, prisms, pyramids, mixed) by the deformation method",
    after_help = "Exit codes: 0 success; 1 bad input (the message names the file, line, field or element); \
                  2 the mesh is or would be invalid (the elements are named, nothing is written); \
                  3 a linear solver failed (not the input's fault), or no result of curve was certified valid (the snap, its patches and the whole mesh all ended without one; the runs' reasons are said; nothing is written); \
                  4 the run needs more memory than it may have (the estimate and what would fit are said; nothing is written); \
                  64 a usage error (an unknown option, a missing or malformed argument, an output that is an input); \
                  69 a library the command needs is absent (Gmsh's, for --cad); \
                  73 an output would replace a file no run of deformesh wrote (--force replaces it; nothing is written); \
                  74 writing the outputs failed (a full disk, an I/O error; nothing is written); 130 interrupted (Ctrl-C)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case file (TOML) and write mesh.msh, mesh.vtu, mesh.png, report.json.
    Run {
        /// The case file.
        case: PathBuf,
        /// Output folder (default: out/<case name>).
        #[arg(short, long)]
        out: Option<PathBuf>,
        /// Replace files of the outputs' names that no run of deformesh
        /// wrote (or that changed since), and write into a folder that is
        /// not an earlier run's.
        #[arg(long)]
        force: bool,
    },
    /// Run the built-in case: the unit square onto a quarter disk (the seed's Figure 2).
    Demo {
        /// Output folder.
        #[arg(short, long, default_value = "out/demo")]
        out: PathBuf,
        /// Replace files of the outputs' names that no run of deformesh
        /// wrote (or that changed since).
        #[arg(long)]
        force: bool,
    },
    /// Curve a user's linear mesh: bind its boundary to exact shapes (the
    /// CAD model it was meshed from, or a geometry file), run Algorithms 2
    /// and 3, write OUT.msh (with OUT.vtu, OUT.png, OUT.report.json beside
    /// it) if every element is certified valid.
    Curve(CurveArgs),
    /// Print quality figures of a triangle, quad, tetrahedral or hex mesh (linear or high order) in Gmsh MSH format.
    Quality {
        /// The mesh file.
        mesh: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Time one step (assembly + factorisation + solve) at several sizes.
    Bench {
        /// Cells per side.
        #[arg(long, value_delimiter = ',', default_values_t = vec![100, 200, 400, 800])]
        sizes: Vec<usize>,
        /// Repetitions per size (the median is reported).
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// 2: the quarter disk on n² quads; 3: the quarter ball on n³ hexes.
        #[arg(long, default_value_t = 2)]
        dim: usize,
        /// auto, cholesky, cholesky_cg, cg or amg.
        #[arg(long, default_value = "auto")]
        solver: String,
    },
}

/// The arguments of `deformesh curve`.
#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("binding").required(true).multiple(true).args(["cad", "geometry"])))]
pub struct CurveArgs {
    /// The linear mesh: triangles, quads, or both; tetrahedra, hexes, prisms, pyramids, alone or mixed (Gmsh MSH 4.1, ASCII or binary, or MSH 2.2).
    pub mesh: PathBuf,
    /// The CAD model the mesh was made from (.step/.stp, .iges/.igs,
    /// .brep, .xao, .geo): each boundary element is curved onto the
    /// model's entity it lies on, found by geometry (the mesh's entity
    /// tags need not be the model's). Loads Gmsh's library (GPL-2+) at
    /// run time: DEFORMESH_GMSH_LIB, else the Python `gmsh` package
    /// (`pip install gmsh`), else the system's.
    #[arg(long)]
    pub cad: Option<PathBuf>,
    /// Multiply the CAD model's coordinates by this factor: 1000 for a
    /// mesh in millimetres made from a model in metres, 0.001 for the
    /// reverse (STEP, IGES and BREP models).
    #[arg(long, default_value_t = 1.0, requires = "cad")]
    pub cad_scale: f64,
    /// The geometry file (TOML `[[group]]` tables: name, kind, shape);
    /// with --cad it may set groups to `slip` or `fixed`, or give them
    /// another shape.
    #[arg(long)]
    pub geometry: Option<PathBuf>,
    #[command(flatten)]
    pub method: MethodArgs,
    /// The curved mesh to write: its extension chooses the format
    /// (`.msh` Gmsh MSH 4.1, `.mesh` MFEM, `.inp` ABAQUS for Trixi.jl).
    #[arg(short, long)]
    pub out: PathBuf,
    /// The format, where the extension does not say it: msh41, msh22
    /// (Gmsh MSH 2.2, `.msh`), mfem or abaqus.
    #[arg(long)]
    pub format: Option<String>,
    /// Replace an existing OUT file (or its .vtu, .png, .report.json)
    /// that no run of deformesh wrote, or that changed since (never an
    /// input).
    #[arg(long)]
    pub force: bool,
}

/// The options of the method in `curve` (also those of the Python
/// package's `deformesh.gmsh.curve`, which has no files to name).
#[derive(clap::Args)]
pub struct MethodArgs {
    /// Element order p, 1 to 4.
    #[arg(long, default_value_t = 3)]
    pub order: usize,
    /// equispaced or gauss_lobatto.
    #[arg(long, default_value = "equispaced")]
    pub spacing: String,
    /// Pseudo-time steps of Algorithm 2 (default: as few as keep every
    /// corner's Jacobian within 25 % of its value in each step).
    #[arg(long)]
    pub steps: Option<usize>,
    /// How new nodes reach the shapes: sliding (default: slide with the
    /// flow, then settle at their intended places), sliding_only (leave
    /// them where sliding put them) or dirichlet (straight paths).
    #[arg(long, default_value = "sliding")]
    pub mode: String,
    /// Linear solver of Algorithm 2: auto, cholesky, cholesky_cg, cg or amg.
    #[arg(long, default_value = "auto")]
    pub solver: String,
    /// How far a node of a curved group may lie from its shape, as a
    /// fraction of its shortest adjacent edge (the geometry file's
    /// `shape_tolerance` may raise it).
    #[arg(long, default_value_t = crate::highorder::curve::DEFAULT_SHAPE_TOLERANCE)]
    pub shape_tolerance: f64,
    /// Algorithm 2 solves within this many bend lengths (a facet's
    /// length along the wall) of the curved walls, the nodes beyond
    /// held (doubled where an element is left invalid with a held
    /// node); `all`: on the whole mesh.
    #[arg(long, default_value_t = crate::refine::ALG2_BAND.to_string())]
    pub band: String,
    /// auto: first put the new boundary nodes on the shapes, nothing
    /// else moved (Gmsh's setOrder), and keep that without running
    /// Algorithm 2 if every element is certified valid and keeps 0.9
    /// of its straight scaled Jacobian or of the straight mesh's least
    /// (its worst element's); never: always Algorithm 2.
    #[arg(long, default_value = "auto")]
    pub snap: String,
    /// auto: then move the inner high-order nodes of the most distorted
    /// triangles and tetrahedra to raise their least distortion (Gmsh's
    /// minSJ), as Gmsh's HighOrderElastic does, every changed element
    /// certified again; never: leave them where the curving put them.
    #[arg(long, default_value = "auto")]
    pub optimise: String,
}

/// Runs the command line `args` (the program's name first) and returns
/// the exit code ([`exit`]): errors are printed on stderr, figures on
/// stdout.
pub fn main(args: impl IntoIterator<Item = impl Into<OsString> + Clone>) -> i32 {
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        // help and version are printed and succeed; anything else is a usage error
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { exit::USAGE } else { exit::OK };
        }
    };
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            exit_code(&e)
        }
    }
}

/// The exit code of an error of [`main`] or [`curve_job`].
pub fn exit_code(e: &anyhow::Error) -> i32 {
    match e.downcast_ref::<RunError>() {
        Some(r) => r.exit_code(),
        None if e.is::<Usage>() => exit::USAGE,
        None => exit::BAD_INPUT,
    }
}


/// A command-line argument whose value is wrong (exit code 64, as clap's
/// own errors).
#[derive(Debug)]
struct Usage(String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// Fails with a [`Usage`] error unless `ok`.
fn usage(ok: bool, message: impl FnOnce() -> String) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Usage(message()).into())
    }
}

fn run(cli: Cli) -> Result<i32> {
    match cli.command {
        Command::Run { case, out, force } => {
            let parsed = Case::read(&case)?;
            let base = case.parent().unwrap_or(Path::new("."));
            let setup = parsed.setup_any(&case.display().to_string(), base)?;
            let name = setup.name().to_string();
            let out = out.unwrap_or_else(|| Path::new("out").join(folder_name(&name)));
            check_run_folder(&out, REPORT, force).map_err(RunError::from)?;
            run_and_print(setup, (&out, force), &case.display().to_string()).map(|()| exit::OK)
        }
        Command::Demo { out, force } => {
            check_run_folder(&out, REPORT, force).map_err(RunError::from)?;
            let setup = Case::parse(DEMO_CASE, "<built-in demo>")?.setup_any("<built-in demo>", Path::new("."))?;
            run_and_print(setup, (&out, force), "<built-in demo>").map(|()| exit::OK)
        }
        Command::Curve(args) => {
            let job = curve_job(&args)?;
            let bar = Bar::new();
            let r = crate::app::driver::curve_file(&job, |p| bar.update(p)).map_err(|e| curve_error(e, &job));
            bar.finish();
            let r = r?;
            if r.reoriented_cells > 0 {
                eprintln!("{} clockwise cell(s) of the input turned counter-clockwise (the method needs counter-clockwise cells; the output has them so)", r.reoriented_cells);
            }
            for g in &r.unbound_groups {
                eprintln!("group `{g}` is not in the geometry file: its nodes stay where they are");
            }
            if let Some(c) = &r.cad {
                println!("{}", format_bound(c, r.dimension));
            }
            print!("{}", format_curved(&r.quality));
            println!(
                "boundary distance: nodes {:.3e}  sampled {:.3e}",
                r.quality.boundary_node_distance, r.quality.boundary_sample_distance
            );
            if let Some(s) = r.quality.boundary_data.sliding_left {
                let left = if s.t == 1.0 {
                    format!("left {} element(s) not certified valid", s.elements)
                } else if s.elements > 0 {
                    format!("inverted {} element(s) of curved facets by t = {:.3}", s.elements, s.t)
                } else {
                    format!("was stopped at t = {:.3}: its first rows' heights changed by {:.2} times themselves per unit t (the sliding drift; the limit is {})", s.t, s.first_row_drift, crate::highorder::curve::DRIFT_LIMIT)
                };
                println!("algorithm 2: sliding {left}; this mesh is from a run with Dirichlet data (straight paths)");
            }
            let memory = r.peak_memory_mib.map_or(String::new(), |m| format!("  peak memory {m:.0} MiB"));
            let snap = &r.quality.snap_first;
            let repair = &r.quality.repair;
            if let Some(o) = &repair.optimised {
                println!("{}", optimised_line(o));
            }
            if let Some(why) = snap.refused.as_ref().filter(|_| repair.won != "whole mesh") {
                println!("snap: not kept as it was ({why})");
                print!("{}", format_candidates(repair));
                println!("time: snap, repair and certification {:.3}s  total {:.3}s{memory}", r.certify_s + r.algorithm2_s, r.total_s);
            } else if snap.kept {
                let places = if snap.fitted { "fitted places" } else { "places at equal arc length (the fitted ones cost a cell its shape)" };
                println!("snap: new boundary nodes put at their {places} on the shapes, every element valid and within {} of its straight scaled Jacobian or of the straight mesh's least: Algorithm 2 not run", crate::highorder::curve::SNAP_KEEP);
                println!("time: snap and certification {:.3}s  total {:.3}s{memory}", r.certify_s + r.algorithm2_s, r.total_s);
            } else {
                if let Some(why) = &snap.refused {
                    println!("snap: not kept ({why})");
                    print!("{}", format_candidates(repair));
                }
                println!("{}", settling_line(&r.quality.settling, r.quality.boundary_data.dirichlet));
                let runs = if r.algorithm2_runs > 1 { format!(", run {} times", r.algorithm2_runs) } else { String::new() };
                println!("time: algorithm 2 {:.3}s ({} steps, {} halved{runs})  certification {:.3}s  total {:.3}s{memory}", r.algorithm2_s, r.steps, r.halved_steps, r.certify_s, r.total_s);
            }
            println!("wrote {}", r.outputs.join(", "));
            Ok(exit::OK)
        }
        Command::Quality { mesh, json } => {
            let (text, value, invalid) = match quality_of(&mesh)? {
                Figures::Linear(q) => (crate::quality::format_quality(&q), serde_json::to_value(&q)?, q.invalid_cells.len()),
                Figures::Curved(q) => (format_curved(&q), serde_json::to_value(&q)?, q.invalid_elements.len()),
            };
            if json {
                println!("{}", serde_json::to_string_pretty(&value)?);
            } else {
                print!("{text}");
            }
            Ok(if invalid > 0 { exit::INVALID_MESH } else { exit::OK })
        }
        Command::Bench { sizes, repeat, dim, solver } => {
            let solver = solver_choice(&solver)?;
            usage(dim == 2 || dim == 3, || format!("--dim must be 2 or 3, got {dim}"))?;
            println!(
                "{:>6} {:>10} {:>11} {:>11} {:>11} {:>11} {:>6} {:>12} {:>6} {:>11} {:>11} {:>10}",
                "cells", "unknowns", "assemble_s", "factor_s", "solve_s", "step_s", "iters", "us/unknown", "cores", "first_s", "setup_s", "peak_MiB"
            );
            for n in sizes {
                let b = if dim == 2 { crate::app::bench::one_step(n, repeat, solver) } else { crate::app::bench::one_step_3d(n, repeat, solver) };
                let b = b.map_err(|e| anyhow::anyhow!(e))?;
                println!(
                    "{:>6} {:>10} {:>11.4} {:>11.4} {:>11.4} {:>11.4} {:>6} {:>12.3} {:>6.2} {:>11.4} {:>11.4} {:>10}",
                    format!("{n}{}", if dim == 2 { "²" } else { "³" }),
                    b.unknowns,
                    b.assemble_s,
                    b.factor_s,
                    b.solve_s,
                    b.step_s(),
                    b.iterations,
                    1e6 * b.step_s() / b.unknowns as f64,
                    b.cores_busy,
                    b.first_step_s,
                    b.setup_s,
                    crate::app::bench::peak_memory_mib().map_or("n/a".to_string(), |m| format!("{m:.0}"))
                );
            }
            Ok(exit::OK)
        }
    }
}

/// The options of the method, checked: each error names its flag.
pub fn method_options(m: &MethodArgs) -> Result<crate::highorder::curve::CurveOptions> {
    let MethodArgs { order, spacing, steps, mode, solver, shape_tolerance, band, snap, optimise } = m;
    let (order, steps, shape_tolerance) = (*order, *steps, *shape_tolerance);
    usage(shape_tolerance.is_finite() && shape_tolerance > 0.0, || format!("--shape-tolerance must be a positive number, got {shape_tolerance}"))?;
    crate::highorder::check_order(order).map_err(|e| Usage(format!("--order: {e}")))?;
    usage(steps != Some(0), || "--steps must be at least 1".into())?;
    let spacing: crate::highorder::Spacing = serde_json::from_value(serde_json::Value::String(spacing.clone()))
        .map_err(|_| Usage(format!("--spacing must be equispaced or gauss_lobatto, got `{spacing}`")))?;
    let (dirichlet, settle) = match mode.as_str() {
        "sliding" => (false, true),
        "sliding_only" => (false, false),
        "dirichlet" => (true, false),
        other => return Err(Usage(format!("--mode must be sliding, sliding_only or dirichlet, got `{other}`")).into()),
    };
    let solver = solver_choice(solver)?;
    let band = match band.as_str() {
        "all" => None,
        // narrower, the cells between the held nodes and the wall
        // are squeezed: the step control then crawls (measured at
        // 0.02 on a 1e-3 layer; 1 ran in 3 steps like the default)
        w => Some(w.parse::<f64>().ok().filter(|w| w.is_finite() && *w >= 1.0).ok_or_else(|| Usage(format!("--band must be a number of facet lengths of at least 1, or `all`, got `{w}`")))?),
    };
    let snap_first = match snap.as_str() {
        "auto" => true,
        "never" => false,
        other => return Err(Usage(format!("--snap must be auto or never, got `{other}`")).into()),
    };
    let optimise = match optimise.as_str() {
        "auto" => true,
        "never" => false,
        other => return Err(Usage(format!("--optimise must be auto or never, got `{other}`")).into()),
    };
    let flow = crate::deform::DeformOptions { solver, ..Default::default() };
    Ok(crate::highorder::curve::CurveOptions { order, spacing, steps, dirichlet, settle, flow, shape_tolerance, band, snap_first, optimise, ..Default::default() })
}

/// The job of `deformesh curve ARGS`, checked: each error names its flag
/// or file.
pub fn curve_job(a: &CurveArgs) -> Result<CurveJob> {
    let cad_scale = a.cad_scale;
    usage(cad_scale.is_finite() && cad_scale > 0.0, || format!("--cad-scale must be a positive number, got {cad_scale}"))?;
    let options = method_options(&a.method)?;
    let format = OutputFormat::choose(&a.out, a.format.as_deref()).map_err(Usage)?;
    usage(!same_file(&a.mesh, &a.out), || format!("-o `{}` is the input mesh: the curved mesh must go to another file", a.out.display()))?;
    crate::io::folder::check_output_file(&a.out).map_err(RunError::from)?;
    let cad = a.cad.clone().map(|model| crate::app::driver::CadSource { model, library: None, scale: cad_scale });
    Ok(CurveJob { input: a.mesh.clone(), geometry: a.geometry.clone(), cad, output: a.out.clone(), format, options, width: 900, force: a.force })
}

/// The job of the command line `deformesh curve ...` given as `args`
/// (the program's name first), without running it.
pub fn parse_curve(args: impl IntoIterator<Item = impl Into<OsString> + Clone>) -> Result<CurveJob> {
    match Cli::try_parse_from(args).map_err(|e| Usage(e.to_string()))?.command {
        Command::Curve(a) => curve_job(&a),
        _ => Err(Usage("not a `curve` command".into()).into()),
    }
}

/// The options of `deformesh.gmsh.curve` (the Python package), as
/// command-line flags without the program's name: the method's, and
/// `--geometry FILE` (groups set to slip, fixed or another shape).
#[derive(Parser)]
#[command(name = "deformesh.gmsh.curve", no_binary_name = true)]
struct LiveCli {
    /// The geometry file.
    #[arg(long)]
    geometry: Option<PathBuf>,
    #[command(flatten)]
    method: MethodArgs,
}

/// The method's options and the geometry file of `args` ([`LiveCli`]),
/// checked: each error names its flag.
pub fn live_options(args: impl IntoIterator<Item = impl Into<OsString> + Clone>) -> Result<(crate::highorder::curve::CurveOptions, Option<PathBuf>)> {
    let a = LiveCli::try_parse_from(args).map_err(|e| Usage(e.to_string()))?;
    Ok((method_options(&a.method)?, a.geometry))
}

/// An error of a `curve` job as the command line says it: prefixed by
/// the input mesh, or the CAD model for the model's errors.
pub fn curve_error(e: RunError, job: &CurveJob) -> anyhow::Error {
    blame_cad(e, &job.input.display().to_string(), job.cad.as_ref().map(|c| c.model.as_path()))
}

fn solver_choice(name: &str) -> Result<SolverChoice> {
    serde_json::from_value(serde_json::Value::String(name.to_string())).map_err(|_| Usage(format!("--solver must be auto, cholesky, cholesky_cg, cg or amg, got `{name}`")).into())
}

/// Whether two paths name one file (the second need not exist).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// An error of a run, prefixed by the input it comes from, except an output
/// folder's error: that names its own path and is no fault of the input.
fn blame(e: RunError, input: &str) -> anyhow::Error {
    match e {
        RunError::Folder(_) => e.into(),
        other => anyhow::Error::from(other).context(input.to_string()),
    }
}

/// [`blame`] for `curve`: an error of the CAD model is prefixed by the
/// model's file (Gmsh's library missing, by nothing).
fn blame_cad(e: RunError, input: &str, cad: Option<&Path>) -> anyhow::Error {
    use crate::geometry::cad::CadError;
    match (e, cad) {
        // these name their own file, or none
        (e @ RunError::Cad(CadError::Absent { .. } | CadError::Library { .. } | CadError::Extension { .. } | CadError::Unscalable { .. }), _) => e.into(),
        (RunError::Read { path, cause }, Some(model)) if path == model => RunError::Read { path, cause }.into(),
        (e @ RunError::Cad(_), Some(model)) => anyhow::Error::from(e).context(model.display().to_string()),
        (e, _) => blame(e, input),
    }
}

fn run_and_print(setup: AnySetup, (out, force): (&Path, bool), input: &str) -> Result<()> {
    let bar = Bar::new();
    let report = run_any_with(setup, out, force, |p| bar.update(p)).map_err(|e| blame(e, input));
    bar.finish();
    let report = report?;
    println!("case {}: {} cells, {} nodes, {} steps ({} halved)", report.case, report.cells, report.nodes, report.steps, report.halved_steps);
    print!("{}", crate::quality::format_quality(&report.quality));
    println!(
        "J/f: min {:.4}  max {:.4}  L2(J/f-1) {:.3e}  equidistribution CoV {:.3e}",
        report.jf.min, report.jf.max, report.jf.l2_error, report.jf.equidistribution_cov
    );
    println!("cell size ratio largest/smallest: {:.3}", report.quality.cell_size.max / report.quality.cell_size.min);
    println!("boundary distance max: {:.3e}", report.boundary_distance_max);
    if let Some(h) = &report.highorder {
        print!("{}", format_curved(&h.quality));
        println!(
            "curved boundary distance: nodes {:.3e}  sampled {:.3e}",
            h.quality.boundary_node_distance, h.quality.boundary_sample_distance
        );
        println!(
            "time: algorithm 1 {:.3}s  algorithm 2 {:.3}s ({} steps, {} halved)  certification {:.3}s",
            h.algorithm1_s, h.algorithm2_s, h.steps, h.halved_steps, h.certify_s
        );
    }
    println!(
        "time: assembly {:.3}s  analyse {:.3}s  factor {:.3}s  solve {:.3}s  total {:.3}s",
        report.time.assembly_s, report.time.analyze_s, report.time.factor_s, report.time.solve_s, report.time.total_s
    );
    println!("wrote {} into {}", report.outputs.join(", "), out.display());
    Ok(())
}

/// A progress bar on a terminal, plain lines every 10% otherwise.
struct Bar {
    bar: Option<ProgressBar>,
    last: std::cell::Cell<i64>,
}

impl Bar {
    fn new() -> Bar {
        let bar = std::io::stderr().is_terminal().then(|| {
            let b = ProgressBar::new(1000);
            b.set_style(ProgressStyle::with_template("{bar:40} t = {msg} [{elapsed_precise}]").expect("valid template"));
            b
        });
        Bar { bar, last: std::cell::Cell::new(-1) }
    }

    fn update(&self, p: Progress) {
        match &self.bar {
            Some(b) => {
                b.set_position((p.t * 1000.0) as u64);
                b.set_message(format!("{:.3}  algorithm {}  steps {}  halved {}  CG iterations {}", p.t, p.algorithm, p.steps, p.halved, p.iterations));
            }
            None => {
                // deciles of each algorithm in turn: algorithm 2 starts again at t = 0
                let decile = 100 * p.algorithm as i64 + (p.t * 10.0 + 1e-9).floor() as i64;
                if decile > self.last.get() {
                    self.last.set(decile);
                    eprintln!("algorithm {}: t = {:.3}  steps {}  halved {}  CG iterations {}", p.algorithm, p.t, p.steps, p.halved, p.iterations);
                }
            }
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// A case name made safe as one folder name under `out/`.
pub fn folder_name(name: &str) -> String {
    let safe: String = name.chars().map(|c| if c.is_alphanumeric() || "-_.".contains(c) { c } else { '_' }).collect();
    if safe.trim_matches('.').is_empty() { "case".into() } else { safe }
}

/// The figures of a linear or a curved mesh.
enum Figures {
    Linear(crate::quality::MeshQuality),
    Curved(CurvedQuality),
}

/// The figures of a curved mesh as lines a person reads.
fn format_curved(q: &CurvedQuality) -> String {
    format!(
        "order {} elements {}  nodes {}\n\
         det J (reference [0,1]^d, certified by Bezier bounds): min >= {:.6e} (attained {:.6e})  max <= {:.6e}\n\
         scaled Jacobian (per element min): min {:.4}  max {:.4}\n\
         invalid elements: {}{}\n",
        q.order,
        q.elements,
        q.nodes,
        q.min_det_j,
        q.min_det_j_attained,
        q.max_det_j,
        q.scaled_jacobian.min,
        q.scaled_jacobian.max,
        q.invalid_elements.len(),
        if q.invalid_elements.is_empty() { String::new() } else { format!(" {:?}", &q.invalid_elements[..q.invalid_elements.len().min(20)]) }
    )
}

/// Quality figures of a linear or high-order MSH file of one kind of cell, with
/// invalid cells named by their element tags in the file.
fn quality_of(path: &Path) -> Result<Figures> {
    use crate::io::msh::AnyMesh;
    let named = |e: MshError| match e {
        MshError::Io { .. } => anyhow::Error::from(e),
        other => anyhow::Error::from(other).context(path.display().to_string()),
    };
    let bytes = std::fs::read(path).map_err(|e| named(MshError::Io { path: path.to_path_buf(), source: e }))?;
    let read = crate::io::msh::parse_any(&bytes, false).map_err(named)?;
    let tags = read.cell_tags;
    // linear quads, triangles, hexes or tetrahedra alone: Algorithm 1's
    // figures of them; else the certificate's (linear meshes of several
    // kinds as the order-1 case of the mesh of any order)
    let mut q = match read.mesh {
        AnyMesh::Plane(m) => match (m.to_plane::<4>(), m.to_plane::<3>()) {
            (Some(quads), _) => crate::quality::mesh_quality(&quads),
            (_, Some(triangles)) => crate::quality::mesh_quality(&triangles),
            _ => return curved_figures((m, tags)),
        },
        AnyMesh::Solid(m) => match (m.to_solid::<8, 4>(), m.to_solid::<4, 3>()) {
            (Some(hexes), _) => crate::quality::hex_mesh_quality(&hexes),
            (_, Some(tets)) => crate::quality::tet_mesh_quality(&tets),
            _ => return curved_figures((m, tags)),
        },
    };
    q.invalid_cells = to_tags(&q.invalid_cells, &tags);
    Ok(Figures::Linear(q))
}

/// The figures of a curved mesh read with its element tags.
fn curved_figures<const D: usize>((mesh, tags): (crate::mesh::CurvedMesh<D>, Vec<u64>)) -> Result<Figures> {
    let mut q = certify_mesh(&mesh).map_err(anyhow::Error::from)?.1;
    q.invalid_elements = to_tags(&q.invalid_elements, &tags);
    Ok(Figures::Curved(q))
}

/// Cell indices as the file's element tags.
fn to_tags(cells: &[usize], tags: &[u64]) -> Vec<usize> {
    cells.iter().map(|&c| tags.get(c).map_or(c, |&t| t as usize)).collect()
}

/// One line on the settling pass of `curve`.
fn settling_line(s: &crate::highorder::curve::Settling, dirichlet: bool) -> String {
    match (&s.kept_sliding, s.how) {
        (Some(why), _) => format!("settling: nodes left where {} put them ({why})", if dirichlet { "the Dirichlet data" } else { "sliding" }),
        (None, how) => {
            let demoted = if s.demoted_elements.is_empty() {
                String::new()
            } else {
                format!("; {} element(s) (0-based) kept nearer their sliding places to stay valid: {:?}", s.demoted_elements.len(), s.demoted_elements)
            };
            let places = if s.fitted { "fitted places" } else { "places at equal arc length (the fitted ones cost a cell its shape)" };
            format!("settling: new boundary nodes put at their {places} along the arcs ({}, largest move {:.2e}){demoted}", how.unwrap_or("-"), s.largest_move)
        }
    }
}

/// One line on how the mesh's boundary was bound to the CAD model.
fn format_bound(c: &crate::app::driver::CadReport, dim: usize) -> String {
    let word = if dim == 2 { "curve" } else { "surface" };
    let model: std::collections::BTreeSet<&String> = c.bound.iter().flat_map(|b| b.model.keys()).collect();
    let by_tag = c.bound.iter().filter(|b| b.by_tag).count();
    let far = c.bound.iter().map(|b| b.max_distance).fold(0.0, f64::max);
    let scale = if c.scale != 1.0 { format!(", the model scaled by {}", c.scale) } else { String::new() };
    format!(
        "cad: {} {word}(s) of the mesh bound by geometry to {} {word}(s) of the model ({by_tag} of them on the model's {word} of their own tag){scale}; boundary nodes within {far:.3e} of them",
        c.bound.len(),
        model.len()
    )
}

/// What the optimiser of the inner nodes did ([`crate::highorder::optimise`]).
fn optimised_line(o: &crate::highorder::optimise::Optimised) -> String {
    format!(
        "optimised: {} inner node(s) of {} element(s) moved, the least distortion (det J over the straight element's: Gmsh's minSJ) from {:.4} to {:.4}, every changed element certified valid ({:.3}s; ended: {})",
        o.nodes_moved, o.elements_changed, o.least_distortion_before, o.least_distortion, o.seconds, o.ended
    )
}

/// The candidates of a `curve` run after a refused snap, a line each, and
/// which was written and why.
fn format_candidates(r: &crate::highorder::repair::Repair) -> String {
    let mut out = String::new();
    for c in r.candidates.iter().filter(|c| c.name != "snap") {
        let size = match c.rings {
            Some(k) => format!(" of {k} rings ({} elements, {:.1} % of the mesh)", c.elements, 100.0 * c.share),
            None => String::new(),
        };
        out += &format!("candidate: {}{size}: {} ({:.3}s)\n", c.name, c.outcome(), c.seconds);
    }
    out += &format!("written: {}: {}\n", r.won, r.why);
    out
}
