//! Brute-force Hamming matching with OpenCV's cross-check.

/// A correspondence between descriptor `query` (first set) and `train` (second set).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Match {
    pub query: u32,
    pub train: u32,
    /// Hamming distance in bits, 0..=256.
    pub distance: u32,
}

/// Hamming distance of two 256-bit descriptors.
#[inline]
#[must_use]
pub fn hamming(a: &[u8; 32], b: &[u8; 32]) -> u32 {
    let w = |d: &[u8; 32], i: usize| u64::from_le_bytes(d[8 * i..8 * i + 8].try_into().unwrap_or([0; 8]));
    (0..4).map(|i| (w(a, i) ^ w(b, i)).count_ones()).sum()
}

/// Brute-force matching with cross-check, with the semantics of OpenCV's
/// `BFMatcher(NORM_HAMMING, crossCheck=True).match` (core `batchDistance` with crosscheck):
/// each train descriptor picks its nearest query (the first one on ties); each query then keeps,
/// among the train descriptors that picked it, the nearest (the first on ties). Matches come in
/// query order.
///
/// This differs from "mutual nearest neighbours" only on ties and when a query's own nearest
/// train descriptor picked another query: OpenCV then pairs the query with the nearest train
/// descriptor that did pick it.
#[must_use]
pub fn match_cross_check(query: &[[u8; 32]], train: &[[u8; 32]]) -> Vec<Match> {
    if query.is_empty() || train.is_empty() {
        return Vec::new();
    }
    let nt = train.len();
    // Train set as four arrays of 64-bit words (structure of arrays) so the inner loop vectorises.
    let word = |d: &[u8; 32], i: usize| u64::from_le_bytes(d[8 * i..8 * i + 8].try_into().unwrap_or([0; 8]));
    let t: [Vec<u64>; 4] = std::array::from_fn(|i| train.iter().map(|d| word(d, i)).collect());
    let mut best_d = vec![u32::MAX; nt];
    let mut best_q = vec![0u32; nt];
    let mut row = vec![0u32; nt];
    for (qi, q) in query.iter().enumerate() {
        let qw = [word(q, 0), word(q, 1), word(q, 2), word(q, 3)];
        distances_dispatch(&qw, &t, &mut row);
        update_min(&row, qi as u32, &mut best_d, &mut best_q);
    }
    let mut per_query: Vec<Option<(u32, u32)>> = vec![None; query.len()];
    for j in 0..nt {
        let (q, d) = (best_q[j] as usize, best_d[j]);
        match per_query[q] {
            Some((bd, _)) if bd <= d => {}
            _ => per_query[q] = Some((d, j as u32)),
        }
    }
    per_query
        .into_iter()
        .enumerate()
        .filter_map(|(q, m)| m.map(|(distance, train)| Match { query: q as u32, train, distance }))
        .collect()
}

#[inline(always)]
fn distances(q: &[u64; 4], t: &[Vec<u64>; 4], out: &mut [u32]) {
    let n = out.len();
    let (t0, t1, t2, t3) = (&t[0][..n], &t[1][..n], &t[2][..n], &t[3][..n]);
    for j in 0..n {
        out[j] = (q[0] ^ t0[j]).count_ones()
            + (q[1] ^ t1[j]).count_ones()
            + (q[2] ^ t2[j]).count_ones()
            + (q[3] ^ t3[j]).count_ones();
    }
}

#[inline(always)]
fn update_min(row: &[u32], qi: u32, best_d: &mut [u32], best_q: &mut [u32]) {
    let n = row.len();
    let (bd, bq) = (&mut best_d[..n], &mut best_q[..n]);
    for j in 0..n {
        let better = row[j] < bd[j];
        bd[j] = if better { row[j] } else { bd[j] };
        bq[j] = if better { qi } else { bq[j] };
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt")]
unsafe fn distances_avx2(q: &[u64; 4], t: &[Vec<u64>; 4], out: &mut [u32]) {
    distances(q, t, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512vpopcntdq,popcnt")]
unsafe fn distances_avx512(q: &[u64; 4], t: &[Vec<u64>; 4], out: &mut [u32]) {
    distances(q, t, out);
}

fn distances_dispatch(q: &[u64; 4], t: &[Vec<u64>; 4], out: &mut [u32]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512vpopcntdq") && std::arch::is_x86_feature_detected!("avx512vl") {
            // SAFETY: the CPU supports these features (checked just above).
            unsafe { distances_avx512(q, t, out) };
            return;
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("popcnt") {
            // SAFETY: the CPU supports AVX2 and POPCNT (checked just above).
            unsafe { distances_avx2(q, t, out) };
            return;
        }
    }
    distances(q, t, out);
}
