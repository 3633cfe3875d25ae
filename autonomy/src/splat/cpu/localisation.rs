//! log det of the 6 x 6 pose information J_tau^T J_tau, by Cholesky.

/// log det of a symmetric positive semi-definite 6 x 6 matrix by Cholesky; `floor` where it
/// is singular (a view of nothing constrains nothing).
pub fn log_det(m: &[[f64; 6]; 6], floor: f64) -> f64 {
    let mut l = [[0.0f64; 6]; 6];
    let mut sum = 0.0;
    for i in 0..6 {
        for j in 0..=i {
            let mut v = m[i][j];
            for k in 0..j {
                v -= l[i][k] * l[j][k];
            }
            if i == j {
                if v <= 1e-300 {
                    return floor;
                }
                l[i][i] = v.sqrt();
                sum += 2.0 * l[i][i].ln();
            } else {
                l[i][j] = v / l[j][j];
            }
        }
    }
    sum.max(floor)
}
