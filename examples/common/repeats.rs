//! Wall times of repeated, interleaved runs: a run of a few seconds on a shared machine
//! varies by several per cent from one run to the next, and the first run of a process
//! can pay for warming caches and page tables; so the examples that compare policies
//! repeat each timed run, alternate which policy goes first, and report medians.

/// The median of `v` (not empty; the mean of the middle two for an even length).
pub fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// `[min, max]` of the ratios `ours[k] / theirs[k]` of runs made side by side.
pub fn ratio_range(ours: &[f64], theirs: &[f64]) -> [f64; 2] {
    ours.iter()
        .zip(theirs)
        .map(|(a, b)| a / b)
        .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], r| {
            [lo.min(r), hi.max(r)]
        })
}

/// Parses a `--repeat` value: a count of at least 1.
pub fn parse_repeat(v: Option<String>) -> Result<usize, String> {
    let v = v.ok_or("--repeat needs a count")?;
    match v.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("--repeat: not a count of at least 1: {v}")),
    }
}

/// The repeats after a first round the caller has made: `walls[i]` holds policy `i`'s
/// first wall time; rounds `1..repeat` time every policy again (`time(i)`, its wall time
/// in seconds) in reverse order for odd rounds and in order for even ones, and push onto
/// `walls[i]`. The order reverses every round: the first and last policies take turns
/// going first (the callers put the controller at one end), and every policy's mean
/// position over two rounds is the same.
pub fn more_rounds<E>(
    walls: &mut [Vec<f64>],
    repeat: usize,
    mut time: impl FnMut(usize) -> Result<f64, E>,
) -> Result<(), E> {
    let n = walls.len();
    for k in 1..repeat {
        for j in 0..n {
            let i = if k % 2 == 1 { n - 1 - j } else { j };
            walls[i].push(time(i)?);
        }
    }
    Ok(())
}
