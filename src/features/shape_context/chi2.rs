//! The χ² cost between shape context histograms (eq. 38) and the vertex matching drawn from
//! it ([`match_vertices`]).

use super::{ShapeContextError, ShapeDescriptor, VertexMatching};

/// χ² cost between two normalised histograms (eq. 38):
/// `C = ½ Σ_k (A(k) − B(k))² / (A(k) + B(k))`, terms with `A(k) + B(k) = 0` skipped.
///
/// For histograms that each sum to 1 the cost lies in `[0, 1]`; it is 0 iff they are equal.
pub fn chi2_cost(a: &[f64], b: &[f64]) -> Result<f64, ShapeContextError> {
    if a.len() != b.len() {
        return Err(ShapeContextError::HistogramLength {
            a: a.len(),
            b: b.len(),
        });
    }
    Ok(chi2_unchecked(a, b))
}

#[inline]
fn chi2_unchecked(a: &[f64], b: &[f64]) -> f64 {
    let mut c = 0.0;
    for (&x, &y) in a.iter().zip(b) {
        let s = x + y;
        if s > 0.0 {
            let d = x - y;
            c += d * d / s;
        }
    }
    0.5 * c
}

/// The `a.len() × b.len()` matrix of χ² costs between every A and every B histogram
/// (row-major).
pub fn chi2_matrix(
    a: &ShapeDescriptor,
    b: &ShapeDescriptor,
) -> Result<Vec<f64>, ShapeContextError> {
    if a.bins != b.bins {
        return Err(ShapeContextError::HistogramLength {
            a: a.bins,
            b: b.bins,
        });
    }
    // χ² over A's non-zero bins only: where A(k) = 0 the term is B(k)²/B(k) = B(k), so those
    // bins together contribute ΣB − Σ_{A(k)>0} B(k). Contour histograms are sparse (n − 1
    // points over 60 bins), so this skips most of the divisions of the dense formula.
    let sums_b: Vec<f64> = b
        .histograms
        .chunks_exact(b.bins)
        .map(|h| h.iter().sum())
        .collect();
    let mut nz: Vec<(usize, f64)> = Vec::with_capacity(a.bins);
    let mut m = Vec::with_capacity(a.len() * b.len());
    for ha in a.histograms.chunks_exact(a.bins) {
        nz.clear();
        nz.extend(ha.iter().copied().enumerate().filter(|&(_, v)| v > 0.0));
        for (hb, &sum_b) in b.histograms.chunks_exact(b.bins).zip(&sums_b) {
            let (mut acc, mut covered) = (0.0, 0.0);
            for &(k, x) in &nz {
                let y = hb.get(k).copied().unwrap_or(0.0);
                let d = x - y;
                acc += d * d / (x + y);
                covered += y;
            }
            m.push((0.5 * (acc + sum_b - covered)).max(0.0));
        }
    }
    Ok(m)
}

/// Matched vertex pairs `(index in A, index in B, χ² cost)` under `rule`.
pub fn match_vertices(
    a: &ShapeDescriptor,
    b: &ShapeDescriptor,
    rule: VertexMatching,
) -> Result<Vec<(usize, usize, f64)>, ShapeContextError> {
    let cost = chi2_matrix(a, b)?;
    let (na, nb) = (a.len(), b.len());
    match rule {
        VertexMatching::Optimal => {
            let (rows, cols) =
                lsap::solve(na, nb, &cost, false).map_err(|e| ShapeContextError::Assignment {
                    reason: e.to_string(),
                })?;
            Ok(rows
                .into_iter()
                .zip(cols)
                .filter_map(|(i, j)| cost.get(i * nb + j).map(|&c| (i, j, c)))
                .collect())
        }
        VertexMatching::NearestCost => Ok(cost
            .chunks_exact(nb)
            .enumerate()
            .filter_map(|(i, row)| {
                row.iter()
                    .enumerate()
                    .min_by(|x, y| x.1.total_cmp(y.1))
                    .map(|(j, &c)| (i, j, c))
            })
            .collect()),
    }
}
