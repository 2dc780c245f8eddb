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

/// Brute-force matching with cross-check, as OpenCV's
/// `BFMatcher(NORM_HAMMING, crossCheck=True).match`: query i and train j match when j is i's
/// nearest train descriptor and i is j's nearest query descriptor, the first index winning ties
/// on both sides (verified against OpenCV 5.0.0). Matches come in query order.
#[must_use]
pub fn match_cross_check(query: &[[u8; 32]], train: &[[u8; 32]]) -> Vec<Match> {
    if query.is_empty() || train.is_empty() {
        return Vec::new();
    }
    let nt = train.len();
    // Train set as four arrays of 64-bit words (structure of arrays) so the inner loop vectorises.
    let word = |d: &[u8; 32], i: usize| u64::from_le_bytes(d[8 * i..8 * i + 8].try_into().unwrap_or([0; 8]));
    let t: [Vec<u64>; 4] = std::array::from_fn(|i| train.iter().map(|d| word(d, i)).collect());
    let mut col_d = vec![u32::MAX; nt];
    let mut col_q = vec![0u32; nt];
    let mut row = vec![0u32; nt];
    let mut nearest: Vec<(u32, u32)> = Vec::with_capacity(query.len());
    for (qi, q) in query.iter().enumerate() {
        let qw = [word(q, 0), word(q, 1), word(q, 2), word(q, 3)];
        nearest.push(query_row_dispatch(&qw, &t, &mut row, qi as u32, &mut col_d, &mut col_q));
    }
    nearest
        .into_iter()
        .enumerate()
        .filter(|&(qi, (j, _))| col_q[j as usize] == qi as u32)
        .map(|(qi, (train, distance))| Match { query: qi as u32, train, distance })
        .collect()
}

/// Distances of one query to every train descriptor; folds them into the per-train minima
/// (first query wins ties) and returns the query's nearest train index and distance (first wins).
#[inline(always)]
fn query_row(
    q: &[u64; 4],
    t: &[Vec<u64>; 4],
    row: &mut [u32],
    qi: u32,
    col_d: &mut [u32],
    col_q: &mut [u32],
) -> (u32, u32) {
    let n = row.len();
    let (t0, t1, t2, t3) = (&t[0][..n], &t[1][..n], &t[2][..n], &t[3][..n]);
    let (cd, cq) = (&mut col_d[..n], &mut col_q[..n]);
    let mut m = u32::MAX;
    for j in 0..n {
        let d = (q[0] ^ t0[j]).count_ones()
            + (q[1] ^ t1[j]).count_ones()
            + (q[2] ^ t2[j]).count_ones()
            + (q[3] ^ t3[j]).count_ones();
        row[j] = d;
        let better = d < cd[j];
        cd[j] = if better { d } else { cd[j] };
        cq[j] = if better { qi } else { cq[j] };
        m = m.min(d);
    }
    let j = row.iter().position(|&d| d == m).unwrap_or(0);
    (j as u32, m)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt")]
unsafe fn query_row_avx2(
    q: &[u64; 4],
    t: &[Vec<u64>; 4],
    row: &mut [u32],
    qi: u32,
    cd: &mut [u32],
    cq: &mut [u32],
) -> (u32, u32) {
    query_row(q, t, row, qi, cd, cq)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512vpopcntdq,popcnt")]
unsafe fn query_row_avx512(
    q: &[u64; 4],
    t: &[Vec<u64>; 4],
    row: &mut [u32],
    qi: u32,
    cd: &mut [u32],
    cq: &mut [u32],
) -> (u32, u32) {
    query_row(q, t, row, qi, cd, cq)
}

fn query_row_dispatch(
    q: &[u64; 4],
    t: &[Vec<u64>; 4],
    row: &mut [u32],
    qi: u32,
    cd: &mut [u32],
    cq: &mut [u32],
) -> (u32, u32) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512vpopcntdq") && std::arch::is_x86_feature_detected!("avx512vl") {
            // SAFETY: the CPU supports these features (checked just above).
            return unsafe { query_row_avx512(q, t, row, qi, cd, cq) };
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("popcnt") {
            // SAFETY: the CPU supports AVX2 and POPCNT (checked just above).
            return unsafe { query_row_avx2(q, t, row, qi, cd, cq) };
        }
    }
    query_row(q, t, row, qi, cd, cq)
}
