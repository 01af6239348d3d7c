//! How the report times things: one warm-up run, then the median of several
//! timed repetitions (wall clock). Operations much shorter than a
//! millisecond are repeated in batches long enough for the clock, and the
//! batch time divided by its size.

use std::time::Instant;

/// The timings of one measured case, in seconds per call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// Median over the repetitions.
    pub median: f64,
    /// Fastest repetition.
    pub min: f64,
    /// Slowest repetition.
    pub max: f64,
    /// Timed repetitions (after the warm-up).
    pub reps: usize,
}

impl Timing {
    /// Relative spread of the repetitions: `(max − min) / median`.
    pub fn spread(&self) -> f64 {
        if self.median > 0.0 {
            (self.max - self.min) / self.median
        } else {
            0.0
        }
    }
}

/// Median of a non-empty sample (mean of the middle two for even sizes).
///
/// ```
/// use voxkit::report::timing::median;
/// assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
/// assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
/// ```
pub fn median(xs: &mut [f64]) -> f64 {
    assert!(!xs.is_empty(), "median of nothing");
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    }
}

/// Times `f`: one untimed warm-up call, then `reps` (at least 1) timed
/// calls. An error from `f` ends the measurement.
pub fn time_calls<E>(reps: usize, mut f: impl FnMut() -> Result<(), E>) -> Result<Timing, E> {
    f()?;
    let mut samples = Vec::with_capacity(reps.max(1));
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        f()?;
        samples.push(t.elapsed().as_secs_f64());
    }
    Ok(summarize(samples))
}

/// Times a short `f` per call: a warm-up call sizes a batch of calls lasting
/// about `batch_seconds`, then the median over `reps` batches of the batch
/// time divided by its size.
pub fn time_batched(reps: usize, batch_seconds: f64, mut f: impl FnMut()) -> Timing {
    let t = Instant::now();
    f();
    let once = t.elapsed().as_secs_f64().max(1e-9);
    let batch = ((batch_seconds / once).ceil() as usize).clamp(1, 100_000_000);
    let mut samples = Vec::with_capacity(reps.max(1));
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        for _ in 0..batch {
            f();
        }
        samples.push(t.elapsed().as_secs_f64() / batch as f64);
    }
    summarize(samples)
}

fn summarize(mut samples: Vec<f64>) -> Timing {
    let min = samples.iter().copied().fold(f64::INFINITY, f64::min);
    let max = samples.iter().copied().fold(0.0, f64::max);
    Timing {
        median: median(&mut samples),
        min,
        max,
        reps: samples.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The warm-up call is made and not counted; errors stop the run.
    #[test]
    fn counts_calls() {
        let mut calls = 0;
        let t = time_calls::<()>(4, || {
            calls += 1;
            Ok(())
        })
        .unwrap();
        assert_eq!((calls, t.reps), (5, 4));
        assert!(t.min <= t.median && t.median <= t.max);
        let mut n = 0;
        assert_eq!(
            time_calls(3, || {
                n += 1;
                if n == 2 { Err("stop") } else { Ok(()) }
            }),
            Err("stop")
        );
        assert_eq!(n, 2);
    }
}
