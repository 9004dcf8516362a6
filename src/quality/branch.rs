//! The branch and bound of a polynomial's minimum over its element, one
//! for every kind (Johnen, Remacle, Geuzaine 2013): best first, always
//! cutting the piece with the smallest Bernstein lower bound, dropping the
//! pieces settled. Each kind says how its pieces are cut and where their
//! polynomial takes a value ([`Piece`]: boxes halved in some variables,
//! simplices bisected across their longest edge, prisms cut across the
//! triangle or along z); the search, its stopping rules and the bound of
//! the rounding are here.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use smallvec::SmallVec;

use super::certify::{gamma, Goal, MAX_SUBDIVISION_DEPTH, ZERO_FLOOR};

/// A polynomial in Bernstein form on a piece of a reference element.
pub(crate) trait Piece: Clone {
    /// What cutting needs beside the piece (the kind's tables).
    type Context: ?Sized;
    /// Its Bernstein coefficients: the least is below every value it
    /// takes on the piece.
    fn coefficients(&self) -> &[f64];
    /// The least coefficient at the piece's vertices: a value it takes.
    fn least_vertex(&self, cx: &Self::Context) -> f64;
    /// The parts the piece is cut into for `goal`, and how many
    /// one-variable cuts (a halving in one variable, a bisection) made
    /// them: each adds a rounding bound to the parts' coefficients.
    fn cut(self, cx: &Self::Context, goal: Goal) -> (SmallVec<[Self; 8]>, usize);
}

/// A piece in the heap, ordered so that the heap pops the smallest lower
/// bound first.
struct Item<P> {
    lower: f64,
    piece: P,
    /// How many one-variable cuts made it from the whole element.
    cuts: usize,
}

impl<P> PartialEq for Item<P> {
    fn eq(&self, other: &Self) -> bool {
        self.lower.total_cmp(&other.lower) == Ordering::Equal
    }
}
impl<P> Eq for Item<P> {}
impl<P> PartialOrd for Item<P> {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl<P> Ord for Item<P> {
    fn cmp(&self, other: &Self) -> Ordering {
        // reversed: BinaryHeap is a max-heap
        other.lower.total_cmp(&self.lower)
    }
}

/// The least of the coefficients at `vertices` (the pieces' corners,
/// where a Bernstein polynomial takes its coefficient's value).
pub(super) fn least_at(coef: &[f64], vertices: &[usize]) -> f64 {
    vertices.iter().fold(f64::INFINITY, |m, &v| m.min(coef[v]))
}

fn least(coef: &[f64]) -> f64 {
    coef.iter().fold(f64::INFINITY, |m, &c| m.min(c))
}

/// `(lower, upper, splits)`: a certified lower bound of the minimum of the
/// exact polynomial over the element, a bound above a value it attains,
/// and how many pieces were cut; `root`'s coefficients are within `err` of
/// the exact ones. One cut rounds each coefficient at most `roundings`
/// times (rows of non-negative weights summing to one) on terms whose
/// absolute values sum to at most the largest coefficient plus its error.
/// [`Goal::Sign`] allows `dim ·` [`MAX_SUBDIVISION_DEPTH`] one-variable
/// cuts: `dim` of them halve a piece about as one box halving does.
pub(crate) fn bound_min<P: Piece>(root: &P, cx: &P::Context, dim: usize, roundings: usize, err: f64, goal: Goal) -> (f64, f64, usize) {
    let coef = root.coefficients();
    // a coordinate that is not finite leaves coefficients NaN, which the
    // min and max folds would skip: no bound, never valid
    if !coef.iter().all(|c| c.is_finite()) || !err.is_finite() {
        return (f64::NEG_INFINITY, f64::INFINITY, 0);
    }
    let scale = coef.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    let per_cut = gamma(roundings) * (scale + 2.0 * err);
    let max_cuts = dim * MAX_SUBDIVISION_DEPTH;
    // the sign test compares with the error of the deepest piece allowed
    let margin = err + max_cuts as f64 * per_cut;
    // The floor keeps a minimum of exactly 0 from asking for infinite
    // relative precision; it is absolute, whatever `rel_tol`: tied to it,
    // a bracket to 1e-3 would settle at 1e-12 of the coefficients, and an
    // element whose minimum is positive but smaller would end undecided,
    // not valid.
    let settled = |lower: f64, upper: f64| match goal {
        Goal::Bracket { rel_tol, .. } => lower >= upper - (rel_tol * upper.abs()).max(ZERO_FLOOR * scale),
        Goal::Sign => lower > margin,
    };
    // A vertex value within its error of 0 stays so in every part.
    let exhausted = |cuts: usize, upper: f64, splits: usize| match goal {
        Goal::Bracket { max_splits, .. } => splits >= max_splits,
        Goal::Sign => cuts >= max_cuts || upper <= margin,
    };
    let result = |lower: f64, upper: f64, splits: usize, deepest: usize| {
        let e = if let Goal::Sign = goal { margin } else { err + deepest as f64 * per_cut };
        (lower - e, upper + e, splits)
    };
    let mut upper = root.least_vertex(cx);
    let lower = least(coef);
    // straight and mildly curved elements are settled here, with no copy
    // and no heap
    if settled(lower, upper) || exhausted(0, upper, 0) {
        return result(lower, upper, 0, 0);
    }
    let (mut splits, mut deepest, mut pruned) = (0, 0, f64::INFINITY);
    let mut heap = BinaryHeap::new();
    let mut top = Item { lower, piece: root.clone(), cuts: 0 };
    loop {
        splits += 1;
        let (parts, n) = top.piece.cut(cx, goal);
        let cuts = top.cuts + n;
        deepest = deepest.max(cuts);
        for b in &parts {
            upper = upper.min(b.least_vertex(cx));
        }
        for b in parts {
            let lower = least(b.coefficients());
            if settled(lower, upper) {
                pruned = pruned.min(lower);
            } else {
                heap.push(Item { lower, piece: b, cuts });
            }
        }
        match heap.pop() {
            Some(next) => top = next,
            // every piece was pruned: the minimum is within tol of upper
            None => return result(pruned.min(upper), upper, splits, deepest),
        }
        if settled(top.lower, upper) || exhausted(top.cuts, upper, splits) {
            return result(top.lower.min(pruned), upper, splits, deepest);
        }
    }
}
