//! Scaling measurements of one pseudo-time step (`deformesh bench` and the
//! criterion bench): the quarter-disk problem on an n×n box, timed by phase.

use crate::case::{Case, DEMO_CASE};
use crate::deform::Deformation;
use std::path::Path;

/// Seconds of one step by phase, best of the repetitions.
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
}

impl StepTiming {
    /// One step's cost: assembly + factorisation + solve.
    pub fn step_s(&self) -> f64 {
        self.assemble_s + self.factor_s + self.solve_s
    }
}

/// Prepares the demo case at n×n cells with one nominal step.
pub fn demo_deformation(n: usize) -> Result<Deformation, Box<dyn std::error::Error + Send + Sync>> {
    let mut case = Case::parse(DEMO_CASE, "<built-in demo>")?;
    case.mesh.cells = vec![n, n];
    case.time.steps = 100;
    let s = case.setup("<built-in demo>", Path::new("."))?;
    Ok(Deformation::new(s.mesh, s.parts, s.field, s.options)?)
}

/// Times `repeat` first steps of the demo case at n×n cells.
pub fn one_step(n: usize, repeat: usize) -> Result<StepTiming, Box<dyn std::error::Error + Send + Sync>> {
    let mut best: Option<StepTiming> = None;
    for _ in 0..repeat.max(1) {
        let mut d = demo_deformation(n)?;
        d.step(0.01)?;
        let t = StepTiming {
            unknowns: d.num_unknowns(),
            assemble_s: d.stats.assembly.as_secs_f64(),
            factor_s: d.stats.factor.as_secs_f64(),
            solve_s: d.stats.solve.as_secs_f64(),
            analyze_s: d.stats.analyze.as_secs_f64(),
        };
        if best.is_none_or(|b| t.step_s() < b.step_s()) {
            best = Some(t);
        }
    }
    Ok(best.expect("at least one repetition"))
}
