//! Scaling measurements of one pseudo-time step (`deformesh bench` and the
//! criterion bench): the quarter-disk problem on an n×n box, timed by phase.

use crate::app::case::{AnySetup, Case, DEMO_CASE};
use crate::deform::{Deformation, Deformation3, Q1Mesh, SolverChoice};
use std::path::Path;

/// Seconds of one step by phase, the median run of the repetitions (by
/// step time; this machine is shared and noisy): the second
/// step of a run, warm-started and with the hierarchy of the first (what
/// every later step of a run costs); the first step apart.
#[derive(Clone, Copy, Debug)]
pub struct StepTiming {
    /// Free unknowns.
    pub unknowns: usize,
    /// Assembly (with normalisation).
    pub assemble_s: f64,
    /// Numeric factorisation.
    pub factor_s: f64,
    /// Triangular solves.
    pub solve_s: f64,
    /// Symbolic analysis (once per mesh, not per step).
    pub analyze_s: f64,
    /// Multigrid set-up in the first step (part of `factor_s` there).
    pub setup_s: f64,
    /// CG iterations of the timed step's solve (0 for Cholesky).
    pub iterations: usize,
    /// The first step (set-up and a cold start included), seconds.
    pub first_step_s: f64,
    /// CPU time over wall time of the timed step: how many cores worked
    /// (Linux, from /proc; NaN elsewhere).
    pub cores_busy: f64,
}

impl StepTiming {
    /// One step's cost: assembly + factorisation + solve.
    pub fn step_s(&self) -> f64 {
        self.assemble_s + self.factor_s + self.solve_s
    }
}

/// The quarter-ball case (`cases/quarter_ball.toml`) at n³ cells.
pub const QUARTER_BALL: &str = include_str!("../../cases/quarter_ball.toml");

/// Errors of the benchmark helpers (case, setup or deformation).
pub type BenchError = Box<dyn std::error::Error + Send + Sync>;

/// A built-in case at the given cell counts, its nominal step 0.01.
fn bench_setup(text: &str, name: &str, cells: Vec<usize>, solver: SolverChoice) -> Result<AnySetup, BenchError> {
    let mut case = Case::parse(text, name)?;
    case.mesh.cells = cells;
    case.time.steps = 100;
    case.time.solver = solver;
    Ok(case.setup_any(name, Path::new("."))?)
}

/// Prepares the 2D demo case (the quarter disk) at n×n cells.
pub fn demo_deformation(n: usize, solver: SolverChoice) -> Result<Deformation, BenchError> {
    match bench_setup(DEMO_CASE, "<built-in demo>", vec![n, n], solver)? {
        AnySetup::Quad(s) => Ok(Deformation::new(s.mesh, s.parts, s.field, s.options)?),
        _ => unreachable!("the demo is of quadrilaterals"),
    }
}

/// Prepares the quarter ball at n×n×n cells.
pub fn ball_deformation(n: usize, solver: SolverChoice) -> Result<Deformation3, BenchError> {
    match bench_setup(QUARTER_BALL, "<quarter ball>", vec![n, n, n], solver)? {
        AnySetup::Hex(s) => Ok(Deformation3::new(s.mesh, s.parts, s.field, s.options)?),
        _ => unreachable!("the quarter ball is of hexahedra"),
    }
}

/// Times `repeat` first steps of the 2D demo case at n×n cells.
pub fn one_step(n: usize, repeat: usize, solver: SolverChoice) -> Result<StepTiming, BenchError> {
    time_steps(repeat, || demo_deformation(n, solver))
}

/// Times `repeat` first steps of the quarter ball at n³ cells.
pub fn one_step_3d(n: usize, repeat: usize, solver: SolverChoice) -> Result<StepTiming, BenchError> {
    time_steps(repeat, || ball_deformation(n, solver))
}

/// Peak resident memory of this process so far, in MiB (Linux; None
/// elsewhere).
pub fn peak_memory_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// User + system CPU seconds of this process so far (Linux; NaN elsewhere).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return f64::NAN };
    // fields after the command name, which is in parentheses
    let Some(rest) = stat.rsplit_once(')').map(|(_, r)| r) else { return f64::NAN };
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(f64::NAN);
    // utime and stime are fields 14 and 15 of the line, 12 and 13 here;
    // the kernel counts them in USER_HZ = 100 ticks per second
    (ticks(11) + ticks(12)) / 100.0
}

fn time_steps<M: Q1Mesh<D, N>, const D: usize, const N: usize>(
    repeat: usize,
    prepare: impl Fn() -> Result<Deformation<M, D, N>, BenchError>,
) -> Result<StepTiming, BenchError> {
    let mut runs: Vec<StepTiming> = Vec::new();
    for _ in 0..repeat.max(1) {
        let mut d = prepare()?;
        d.step(0.01)?;
        let first = d.stats.clone();
        let (cpu0, wall0) = (cpu_seconds(), std::time::Instant::now());
        d.step(0.01)?;
        let cores_busy = (cpu_seconds() - cpu0) / wall0.elapsed().as_secs_f64();
        let s = &d.stats;
        let secs = |a: std::time::Duration, b: std::time::Duration| (a - b).as_secs_f64();
        let t = StepTiming {
            unknowns: d.num_unknowns(),
            assemble_s: secs(s.assembly, first.assembly),
            factor_s: secs(s.factor, first.factor),
            solve_s: secs(s.solve, first.solve),
            analyze_s: s.analyze.as_secs_f64(),
            setup_s: first.setup.as_secs_f64(),
            iterations: s.last_iterations,
            first_step_s: (first.assembly + first.factor + first.solve).as_secs_f64(),
            cores_busy,
        };
        runs.push(t);
    }
    runs.sort_by(|a, b| a.step_s().total_cmp(&b.step_s()));
    Ok(runs[runs.len() / 2])
}
