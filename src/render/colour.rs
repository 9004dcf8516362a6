//! Colour maps from cell values to RGB.

/// ColorBrewer "RdBu" (9 classes), reversed so low values are blue and
/// high values red; the middle stop is near-white.
const DIVERGING: [[u8; 3]; 9] = [
    [33, 102, 172],
    [67, 147, 195],
    [146, 197, 222],
    [209, 229, 240],
    [247, 247, 247],
    [253, 219, 199],
    [244, 165, 130],
    [214, 96, 77],
    [178, 24, 43],
];

/// Nine evenly spaced samples of matplotlib's perceptually uniform viridis.
const SEQUENTIAL: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 45, 123],
    [59, 82, 139],
    [44, 114, 142],
    [33, 145, 140],
    [40, 174, 128],
    [94, 201, 98],
    [173, 220, 48],
    [253, 231, 37],
];

/// How cell values are turned into colours.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ColourMap {
    /// Blue below `centre`, near-white at `centre`, red above. Both sides
    /// use the same scale (the larger of the two half-ranges), so equal
    /// deviations from the centre get equally strong colours.
    Diverging {
        /// The value shown as near-white (1 for J/f, where 1 is perfect).
        centre: f64,
    },
    /// A viridis-like map from dark purple (low) to yellow (high).
    Sequential,
}

impl ColourMap {
    /// Picks the map for a colour range: diverging about 1 when the range
    /// contains 1 (the ideal J/f), sequential otherwise.
    pub fn auto(range: (f64, f64)) -> ColourMap {
        if range.0 <= 1.0 && 1.0 <= range.1 {
            ColourMap::Diverging { centre: 1.0 }
        } else {
            ColourMap::Sequential
        }
    }

    /// The colour of `value` for the colour range `range` (low, high).
    /// Values outside the range get the colour of the nearer end.
    pub fn colour(&self, value: f64, range: (f64, f64)) -> [u8; 3] {
        match *self {
            ColourMap::Diverging { centre } => {
                let half = (centre - range.0).max(range.1 - centre);
                let t = if half > 0.0 {
                    0.5 + 0.5 * (value - centre) / half
                } else {
                    0.5
                };
                interpolate(&DIVERGING, t)
            }
            ColourMap::Sequential => {
                let span = range.1 - range.0;
                let t = if span > 0.0 {
                    (value - range.0) / span
                } else {
                    0.5
                };
                interpolate(&SEQUENTIAL, t)
            }
        }
    }
}

/// Piecewise-linear interpolation between evenly spaced colour stops,
/// `t` clamped to [0, 1] (a NaN `t` gives the first stop).
fn interpolate(stops: &[[u8; 3]], t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (stops.len() - 1) as f64;
    let i = (x.floor() as usize).min(stops.len() - 2);
    let f = x - i as f64;
    let (a, b) = (stops[i], stops[i + 1]);
    std::array::from_fn(|k| (a[k] as f64 + f * (b[k] as f64 - a[k] as f64)).round() as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_picks_diverging_only_around_one() {
        assert_eq!(
            ColourMap::auto((0.8, 1.2)),
            ColourMap::Diverging { centre: 1.0 }
        );
        assert_eq!(
            ColourMap::auto((1.0, 3.0)),
            ColourMap::Diverging { centre: 1.0 }
        );
        assert_eq!(ColourMap::auto((1.1, 3.0)), ColourMap::Sequential);
        assert_eq!(ColourMap::auto((0.0, 0.5)), ColourMap::Sequential);
    }

    #[test]
    fn diverging_is_white_at_centre_blue_below_red_above() {
        let m = ColourMap::Diverging { centre: 1.0 };
        let r = (0.85, 1.10);
        assert!(m.colour(1.0, r).iter().all(|&c| c >= 240));
        let low = m.colour(0.85, r);
        assert!(low[2] > low[0] + 80, "low end should be blue: {low:?}");
        let high = m.colour(1.15, (0.85, 1.15));
        assert!(high[0] > high[2] + 80, "high end should be red: {high:?}");
        // symmetric scale: the far end (0.85) is full blue, but 1.10 is
        // closer to 1 and so only reaches part of the red side
        assert_eq!(m.colour(0.85, r), DIVERGING[0]);
        assert_ne!(m.colour(1.10, r), DIVERGING[8]);
        assert_eq!(m.colour(1.15, r), DIVERGING[8]);
    }

    #[test]
    fn sequential_runs_from_dark_to_bright() {
        let m = ColourMap::Sequential;
        assert_eq!(m.colour(2.0, (2.0, 4.0)), SEQUENTIAL[0]);
        assert_eq!(m.colour(4.0, (2.0, 4.0)), SEQUENTIAL[8]);
        assert_eq!(m.colour(9.0, (2.0, 4.0)), SEQUENTIAL[8]);
        assert_eq!(m.colour(3.0, (2.0, 4.0)), SEQUENTIAL[4]);
    }
}
