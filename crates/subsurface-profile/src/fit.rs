//! Fitting a sum of K Gaussians (shared variances, per-channel non-negative
//! weights) to any radial profile.
//!
//! What is fitted is `r R(r)`, the profile's energy per unit radius, in the L2
//! norm over `0..=r_max`; that is the quantity a renderer's blur integrates, and it
//! keeps the steep peak at `r = 0` from dominating. For fixed variances the
//! weights are a non-negative least-squares problem (Lawson and Hanson); the
//! variances are found by Nelder-Mead on their logarithms, started from the
//! clusters that NNLS picks on a dense log-spaced grid of candidate variances.

use serde::Serialize;

use crate::error::{Result, count, positive};
use crate::gaussian::{GaussianTerm, SumOfGaussians, gaussian};

/// Result of [`fit_sum_of_gaussians`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GaussianFit {
    /// The fitted profile (terms sorted by variance; weights are absolute, so
    /// `total_weight` approximates the profile's total reflectance).
    pub profile: SumOfGaussians,
    /// Per channel `||r (R - fit)|| / ||r R||` over `0..=r_max_mm` (0 for a
    /// channel that is identically zero).
    pub rel_l2_error: [f64; 3],
    /// Radius the fit covered, mm.
    pub r_max_mm: f64,
}

impl GaussianFit {
    /// Worst channel's relative L2 error.
    pub fn max_error(&self) -> f64 {
        self.rel_l2_error.iter().copied().fold(0.0, f64::max)
    }
}

/// Grid points in `r` (and rows of the least-squares problems).
const GRID: usize = 400;
/// Candidate variances of the initial NNLS.
const CANDIDATES: usize = 72;

/// The sampled problem: rows are `sqrt(quadrature weight) * r_j * f(r_j)`.
struct Problem {
    r: Vec<f64>,
    sqrt_q: Vec<f64>,
    targets: [Vec<f64>; 3],
    target_norm: [f64; 3],
    ln_v_lo: f64,
    ln_v_hi: f64,
}

impl Problem {
    fn new(profile: &dyn Fn(f64) -> [f64; 3], r_max: f64) -> Self {
        // r = r_max u^2 with u at midpoints: dense near the origin where the
        // profile changes fastest; dr = 2 r_max u du.
        let du = 1.0 / GRID as f64;
        let mut r = Vec::with_capacity(GRID);
        let mut sqrt_q = Vec::with_capacity(GRID);
        let mut targets: [Vec<f64>; 3] = Default::default();
        for j in 0..GRID {
            let u = (j as f64 + 0.5) * du;
            let rj = r_max * u * u;
            let q = 2.0 * r_max * u * du;
            r.push(rj);
            sqrt_q.push(q.sqrt());
            let f = profile(rj);
            for c in 0..3 {
                targets[c].push(q.sqrt() * rj * f[c]);
            }
        }
        let target_norm = [0, 1, 2].map(|c| norm(&targets[c]));
        // Narrowest resolvable Gaussian: a few grid steps at the origin; widest:
        // one spanning the whole range.
        let v_lo = (4.0 * r[1]).powi(2);
        // Widest: sigma = r_max / 2, which still holds 86 % of its energy inside
        // the range; much wider ones would put weight where no data constrains
        // it (an almost flat Gaussian soaking up the tail).
        let v_hi = (r_max / 2.0).powi(2);
        Self {
            r,
            sqrt_q,
            targets,
            target_norm,
            ln_v_lo: v_lo.ln(),
            ln_v_hi: v_hi.ln(),
        }
    }

    fn column(&self, v: f64) -> Vec<f64> {
        self.r
            .iter()
            .zip(&self.sqrt_q)
            .map(|(&r, &q)| q * r * gaussian(v, r))
            .collect()
    }

    /// Best non-negative weights for the given variances and the per-channel
    /// relative errors.
    fn solve(&self, variances: &[f64]) -> ([Vec<f64>; 3], [f64; 3]) {
        let cols: Vec<Vec<f64>> = variances.iter().map(|&v| self.column(v)).collect();
        let mut weights: [Vec<f64>; 3] = Default::default();
        let mut errors = [0.0; 3];
        for c in 0..3 {
            if self.target_norm[c] == 0.0 {
                weights[c] = vec![0.0; variances.len()];
                continue;
            }
            let w = nnls(&cols, &self.targets[c]);
            let mut res = self.targets[c].clone();
            for (col, &wk) in cols.iter().zip(&w) {
                for (ri, &a) in res.iter_mut().zip(col) {
                    *ri -= wk * a;
                }
            }
            errors[c] = norm(&res) / self.target_norm[c];
            weights[c] = w;
        }
        (weights, errors)
    }

    fn clamp_ln_v(&self, x: f64) -> f64 {
        x.clamp(self.ln_v_lo - 2.0, self.ln_v_hi)
    }

    /// Sum over channels of the squared relative error, through the normal
    /// equations: fast, and accurate enough to steer the search (the reported
    /// error comes from [`Problem::solve`]).
    fn objective(&self, ln_v: &[f64]) -> f64 {
        let cols: Vec<Vec<f64>> = ln_v
            .iter()
            .map(|&x| self.column(self.clamp_ln_v(x).exp()))
            .collect();
        let k = cols.len();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let gram: Vec<Vec<f64>> = (0..k)
            .map(|i| (0..k).map(|j| dot(&cols[i], &cols[j])).collect())
            .collect();
        let mut total = 0.0;
        for c in 0..3 {
            if self.target_norm[c] == 0.0 {
                continue;
            }
            let atb: Vec<f64> = cols.iter().map(|col| dot(col, &self.targets[c])).collect();
            let w = nnls_gram(&gram, &atb);
            let btb = self.target_norm[c] * self.target_norm[c];
            let mut r2 = btb;
            for i in 0..k {
                r2 -= 2.0 * w[i] * atb[i];
                for j in 0..k {
                    r2 += w[i] * gram[i][j] * w[j];
                }
            }
            total += r2.max(0.0) / btb;
        }
        total
    }
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|a| a * a).sum::<f64>().sqrt()
}

/// Fits `k` Gaussians to `profile` (a function of `r` in mm returning `R(r)` per
/// channel in mm^-2) over `0..=r_max_mm`.
///
/// `k` must be in 1..=12 and `r_max_mm` finite and > 0; a profile returning
/// non-finite or negative values yields an error naming `profile`.
pub fn fit_sum_of_gaussians(
    profile: impl Fn(f64) -> [f64; 3],
    k: usize,
    r_max_mm: f64,
) -> Result<GaussianFit> {
    count("gaussians", k, 1, 12)?;
    positive("r_max_mm", r_max_mm)?;
    let problem = Problem::new(&profile, r_max_mm);
    for c in 0..3 {
        for &t in &problem.targets[c] {
            crate::error::non_negative("profile", t)?;
        }
    }

    let starts = initial_guesses(&problem, k);
    let mut best: Option<(Vec<f64>, f64)> = None;
    for start in starts {
        let (x, f) = nelder_mead(|x| problem.objective(x), &start, 0.35, 2500);
        if best.as_ref().is_none_or(|(_, fb)| f < *fb) {
            best = Some((x, f));
        }
    }
    let (mut x, mut f) = best.expect("at least one start");
    // Restarts from the best point shake Nelder-Mead out of a collapsed simplex.
    for step in [0.2, 0.05, 0.01] {
        let (x2, f2) = nelder_mead(|x| problem.objective(x), &x, step, 1000);
        if f2 <= f {
            x = x2;
            f = f2;
        }
    }

    let variances: Vec<f64> = x.iter().map(|&l| problem.clamp_ln_v(l).exp()).collect();
    let (w, rel_l2_error) = problem.solve(&variances);
    let terms = variances
        .iter()
        .enumerate()
        .map(|(i, &variance)| GaussianTerm {
            variance,
            weight: [w[0][i], w[1][i], w[2][i]],
        })
        .collect();
    Ok(GaussianFit {
        profile: SumOfGaussians::new(terms)?,
        rel_l2_error,
        r_max_mm,
    })
}

/// Starting log-variances: (a) the clusters of a dense-grid NNLS, merged or
/// split to exactly `k`; (b) `k` log-evenly spaced between the extreme clusters.
fn initial_guesses(p: &Problem, k: usize) -> Vec<Vec<f64>> {
    let ln_grid: Vec<f64> = (0..CANDIDATES)
        .map(|i| p.ln_v_lo + (p.ln_v_hi - p.ln_v_lo) * i as f64 / (CANDIDATES - 1) as f64)
        .collect();
    let cols: Vec<Vec<f64>> = ln_grid.iter().map(|&l| p.column(l.exp())).collect();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let gram: Vec<Vec<f64>> = (0..CANDIDATES)
        .map(|i| (0..CANDIDATES).map(|j| dot(&cols[i], &cols[j])).collect())
        .collect();
    let mut score = vec![0.0; CANDIDATES];
    for c in 0..3 {
        if p.target_norm[c] == 0.0 {
            continue;
        }
        let atb: Vec<f64> = cols.iter().map(|col| dot(col, &p.targets[c])).collect();
        let w = nnls_gram(&gram, &atb);
        for m in 0..CANDIDATES {
            score[m] += w[m] * norm(&cols[m]) / p.target_norm[c];
        }
    }
    let top = score.iter().copied().fold(0.0, f64::max);
    // Clusters of neighbouring active candidates: (score-weighted ln v, score).
    let mut clusters: Vec<(f64, f64)> = Vec::new();
    let mut in_run = false;
    for m in 0..CANDIDATES {
        if score[m] > 1e-9 * top && top > 0.0 {
            if in_run {
                let last = clusters.last_mut().unwrap();
                last.0 += score[m] * ln_grid[m];
                last.1 += score[m];
            } else {
                clusters.push((score[m] * ln_grid[m], score[m]));
            }
            in_run = true;
        } else {
            in_run = false;
        }
    }
    let mut clusters: Vec<(f64, f64)> = clusters.into_iter().map(|(s, w)| (s / w, w)).collect();
    if clusters.is_empty() {
        clusters.push((0.5 * (p.ln_v_lo + p.ln_v_hi), 1.0));
    }
    let (lo, hi) = (clusters[0].0, clusters[clusters.len() - 1].0);
    while clusters.len() > k {
        // Merge the adjacent pair with the least combined energy.
        let i = (0..clusters.len() - 1)
            .min_by(|&a, &b| {
                (clusters[a].1 + clusters[a + 1].1).total_cmp(&(clusters[b].1 + clusters[b + 1].1))
            })
            .unwrap();
        let (a, b) = (clusters[i], clusters[i + 1]);
        clusters[i] = ((a.0 * a.1 + b.0 * b.1) / (a.1 + b.1), a.1 + b.1);
        clusters.remove(i + 1);
    }
    while clusters.len() < k {
        // Split the widest gap (the ends of the candidate range count as edges).
        let mut edges: Vec<f64> = vec![p.ln_v_lo];
        edges.extend(clusters.iter().map(|c| c.0));
        edges.push(p.ln_v_hi);
        let i = (0..edges.len() - 1)
            .max_by(|&a, &b| (edges[a + 1] - edges[a]).total_cmp(&(edges[b + 1] - edges[b])))
            .unwrap();
        let mid = 0.5 * (edges[i] + edges[i + 1]);
        clusters.insert(i, (mid, 0.0));
    }
    let a: Vec<f64> = clusters.iter().map(|c| c.0).collect();
    let b: Vec<f64> = if k == 1 {
        vec![0.5 * (lo + hi)]
    } else {
        (0..k)
            .map(|i| lo + (hi - lo) * i as f64 / (k - 1) as f64)
            .collect()
    };
    vec![a, b]
}

/// Nelder-Mead minimisation from `x0` with an axis-aligned initial simplex of
/// size `step`; returns the best point and value after `max_evals` evaluations
/// or when the simplex values agree to 1e-15 (absolute, the objective is a
/// sum of squared relative errors).
fn nelder_mead(
    f: impl Fn(&[f64]) -> f64,
    x0: &[f64],
    step: f64,
    max_evals: usize,
) -> (Vec<f64>, f64) {
    let n = x0.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((x0.to_vec(), f(x0)));
    for i in 0..n {
        let mut x = x0.to_vec();
        x[i] += step;
        let fx = f(&x);
        simplex.push((x, fx));
    }
    let mut evals = n + 1;
    while evals < max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        if simplex[n].1 - simplex[0].1 <= 1e-15 {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|j| simplex[..n].iter().map(|s| s.0[j]).sum::<f64>() / n as f64)
            .collect();
        let along = |t: f64| -> Vec<f64> {
            (0..n)
                .map(|j| centroid[j] + t * (simplex[n].0[j] - centroid[j]))
                .collect()
        };
        let xr = along(-1.0);
        let fr = f(&xr);
        evals += 1;
        if fr < simplex[0].1 {
            let xe = along(-2.0);
            let fe = f(&xe);
            evals += 1;
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (xc, fc) = if fr < simplex[n].1 {
                let x = along(-0.5);
                let fx = f(&x);
                (x, fx)
            } else {
                let x = along(0.5);
                let fx = f(&x);
                (x, fx)
            };
            evals += 1;
            if fc < simplex[n].1.min(fr) {
                simplex[n] = (xc, fc);
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    for j in 0..n {
                        s.0[j] = best[j] + 0.5 * (s.0[j] - best[j]);
                    }
                    s.1 = f(&s.0);
                    evals += 1;
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

/// Non-negative least squares `min ||A x - b||, x >= 0` (Lawson and Hanson's
/// active-set method); `cols` are the columns of `A`.
pub(crate) fn nnls(cols: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let n = cols.len();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let scale: Vec<f64> = cols.iter().map(|c| norm(c).max(1e-300)).collect();
    let residual = |x: &[f64]| -> Vec<f64> {
        let mut r = b.to_vec();
        for (k, col) in cols.iter().enumerate() {
            if x[k] != 0.0 {
                for (ri, &a) in r.iter_mut().zip(col) {
                    *ri -= x[k] * a;
                }
            }
        }
        r
    };
    let tol = 1e-12 * norm(b).max(1e-300);
    let mut x = vec![0.0; n];
    let mut passive = vec![false; n];
    for _outer in 0..3 * n + 10 {
        let r = residual(&x);
        // Gradient on the scaled problem so the tolerance is scale-free.
        let w: Vec<f64> = (0..n).map(|k| dot(&cols[k], &r) / scale[k]).collect();
        let Some(t) = (0..n)
            .filter(|&k| !passive[k] && w[k] > tol)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]))
        else {
            break;
        };
        passive[t] = true;
        active_set_steps(&mut x, &mut passive, |idx| {
            let sub: Vec<&[f64]> = idx.iter().map(|&k| cols[k].as_slice()).collect();
            least_squares(&sub, b)
        });
        // Guard against the entering variable being dropped straight away.
        if !passive[t] && x[t] == 0.0 {
            let r2 = residual(&x);
            if dot(&cols[t], &r2) / scale[t] <= tol * 10.0 {
                break;
            }
        }
    }
    x
}

/// Non-negative least squares from the normal equations: `gram = A^T A`,
/// `atb = A^T b` (Lawson and Hanson's active set, Cholesky for the
/// sub-problems; a column whose pivot vanishes is left at 0).
fn nnls_gram(gram: &[Vec<f64>], atb: &[f64]) -> Vec<f64> {
    let n = atb.len();
    let scale: Vec<f64> = (0..n).map(|k| gram[k][k].sqrt().max(1e-300)).collect();
    let tol = 1e-13
        * atb
            .iter()
            .zip(&scale)
            .map(|(a, s)| (a / s).abs())
            .fold(0.0, f64::max);
    let grad = |x: &[f64], k: usize| -> f64 {
        (atb[k] - (0..n).map(|j| gram[k][j] * x[j]).sum::<f64>()) / scale[k]
    };
    let mut x = vec![0.0; n];
    let mut passive = vec![false; n];
    for _outer in 0..3 * n + 10 {
        let Some(t) = (0..n)
            .filter(|&k| !passive[k] && grad(&x, k) > tol)
            .max_by(|&a, &b| grad(&x, a).total_cmp(&grad(&x, b)))
        else {
            break;
        };
        passive[t] = true;
        active_set_steps(&mut x, &mut passive, |idx| cholesky_solve(gram, atb, idx));
        if !passive[t] {
            break;
        }
    }
    x
}

/// The inner loop of Lawson and Hanson's active-set method, shared by [`nnls`] and
/// [`nnls_gram`]: `solve` gives the unconstrained least-squares solution over the passive
/// set `idx`; where it is all positive it is taken, else `x` moves towards it as far as
/// feasibility allows and the unknowns that reach (about) zero leave the passive set.
fn active_set_steps(x: &mut [f64], passive: &mut [bool], solve: impl Fn(&[usize]) -> Vec<f64>) {
    let n = x.len();
    for _inner in 0..3 * n + 10 {
        let idx: Vec<usize> = (0..n).filter(|&k| passive[k]).collect();
        let z_sub = solve(&idx);
        if z_sub.iter().all(|&z| z > 0.0) {
            for (&k, &z) in idx.iter().zip(&z_sub) {
                x[k] = z;
            }
            break;
        }
        let mut alpha = 1.0f64;
        for (&k, &z) in idx.iter().zip(&z_sub) {
            if z <= 0.0 && x[k] - z > 0.0 {
                alpha = alpha.min(x[k] / (x[k] - z));
            }
        }
        for (&k, &z) in idx.iter().zip(&z_sub) {
            x[k] += alpha * (z - x[k]);
            // Also catches x[k] <= 0 (the right-hand side is positive).
            if x[k] <= 1e-15 * (1.0 + x[k].abs()) {
                x[k] = 0.0;
                passive[k] = false;
            }
        }
        if !passive.iter().any(|&p| p) {
            break;
        }
    }
}

/// Solves `gram[idx][idx] z = atb[idx]` by Cholesky; a non-positive pivot
/// (dependent column) gives that unknown 0.
fn cholesky_solve(gram: &[Vec<f64>], atb: &[f64], idx: &[usize]) -> Vec<f64> {
    let p = idx.len();
    let mut l = vec![vec![0.0; p]; p];
    let mut ok = vec![true; p];
    for i in 0..p {
        for j in 0..=i {
            let mut s = gram[idx[i]][idx[j]];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s <= 1e-14 * gram[idx[i]][idx[i]] || !ok[i] {
                    ok[i] = false;
                    l[i][i] = 1.0;
                } else {
                    l[i][i] = s.sqrt();
                }
            } else if ok[j] {
                l[i][j] = s / l[j][j];
            } else {
                l[i][j] = 0.0;
            }
        }
    }
    let mut y = vec![0.0; p];
    for i in 0..p {
        if !ok[i] {
            continue;
        }
        let mut s = atb[idx[i]];
        for k in 0..i {
            s -= l[i][k] * y[k];
        }
        y[i] = s / l[i][i];
    }
    let mut z = vec![0.0; p];
    for i in (0..p).rev() {
        if !ok[i] {
            continue;
        }
        let mut s = y[i];
        for k in i + 1..p {
            s -= l[k][i] * z[k];
        }
        z[i] = s / l[i][i];
    }
    z
}

/// Unconstrained least squares by Householder QR (columns given); rank-deficient
/// directions get 0.
fn least_squares(cols: &[&[f64]], b: &[f64]) -> Vec<f64> {
    let m = b.len();
    let n = cols.len();
    // Column-major copy.
    let mut a: Vec<Vec<f64>> = cols.iter().map(|c| c.to_vec()).collect();
    let mut y = b.to_vec();
    let mut diag = vec![0.0; n];
    for k in 0..n.min(m) {
        let alpha_norm = a[k][k..].iter().map(|v| v * v).sum::<f64>().sqrt();
        if alpha_norm == 0.0 {
            diag[k] = 0.0;
            continue;
        }
        let alpha = if a[k][k] > 0.0 {
            -alpha_norm
        } else {
            alpha_norm
        };
        // v = a_k[k..] - alpha e_1
        let mut v: Vec<f64> = a[k][k..].to_vec();
        v[0] -= alpha;
        let vnorm2: f64 = v.iter().map(|x| x * x).sum();
        if vnorm2 == 0.0 {
            diag[k] = alpha;
            continue;
        }
        for col in a.iter_mut().skip(k) {
            let s: f64 = v.iter().zip(&col[k..]).map(|(p, q)| p * q).sum::<f64>() * 2.0 / vnorm2;
            for (ci, vi) in col[k..].iter_mut().zip(&v) {
                *ci -= s * vi;
            }
        }
        let s: f64 = v.iter().zip(&y[k..]).map(|(p, q)| p * q).sum::<f64>() * 2.0 / vnorm2;
        for (yi, vi) in y[k..].iter_mut().zip(&v) {
            *yi -= s * vi;
        }
        diag[k] = a[k][k];
    }
    let max_diag = diag.iter().map(|d| d.abs()).fold(0.0, f64::max);
    let mut x = vec![0.0; n];
    for k in (0..n.min(m)).rev() {
        if diag[k].abs() <= 1e-13 * max_diag {
            x[k] = 0.0;
            continue;
        }
        let mut s = y[k];
        for j in k + 1..n {
            s -= a[j][k] * x[j];
        }
        x[k] = s / diag[k];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nnls_recovers_non_negative_solution_and_clamps_negative() {
        // A = [[1,0],[0,1],[1,1]], b = A [2, 3] -> exact.
        let cols = vec![vec![1.0, 0.0, 1.0], vec![0.0, 1.0, 1.0]];
        let x = nnls(&cols, &[2.0, 3.0, 5.0]);
        assert!(
            (x[0] - 2.0).abs() < 1e-12 && (x[1] - 3.0).abs() < 1e-12,
            "{x:?}"
        );
        // Unconstrained optimum has x1 < 0; NNLS must return x1 = 0.
        let x = nnls(&cols, &[2.0, -3.0, -1.0]);
        assert_eq!(x[1], 0.0);
        assert!((x[0] - 0.5).abs() < 1e-12, "{x:?}"); // min (x-2)^2 + (x+1)^2
    }

    #[test]
    fn fitting_six_gaussians_recovers_the_skin_profile() {
        let skin = SumOfGaussians::skin();
        let r_max = skin.energy_radius_mm(0.999);
        let fit = fit_sum_of_gaussians(|r| skin.eval(r), 6, r_max).unwrap();
        assert!(fit.max_error() < 1e-4, "fit error {:?}", fit.rel_l2_error);
        // Stated tolerance: variances within 2 % and weights within 0.005 of d'Eon's.
        for (got, want) in fit.profile.terms().iter().zip(skin.terms()) {
            assert!(
                (got.variance / want.variance - 1.0).abs() < 0.02,
                "variance {} vs {}",
                got.variance,
                want.variance
            );
            for c in 0..3 {
                assert!(
                    (got.weight[c] - want.weight[c]).abs() < 0.005,
                    "weight {:?} vs {:?}",
                    got.weight,
                    want.weight
                );
            }
        }
    }

    #[test]
    fn more_gaussians_fit_no_worse() {
        let skin = SumOfGaussians::skin();
        let r_max = skin.energy_radius_mm(0.999);
        let e1 = fit_sum_of_gaussians(|r| skin.eval(r), 1, r_max)
            .unwrap()
            .max_error();
        let e3 = fit_sum_of_gaussians(|r| skin.eval(r), 3, r_max)
            .unwrap()
            .max_error();
        assert!(e1 > 0.05, "one Gaussian cannot fit six: {e1}");
        assert!(e3 < e1, "{e3} vs {e1}");
    }

    #[test]
    fn bad_fit_inputs_are_errors() {
        let skin = SumOfGaussians::skin();
        let e = fit_sum_of_gaussians(|r| skin.eval(r), 0, 8.0).unwrap_err();
        assert!(e.to_string().starts_with("gaussians: "), "{e}");
        let e = fit_sum_of_gaussians(|r| skin.eval(r), 3, f64::NAN).unwrap_err();
        assert!(e.to_string().starts_with("r_max_mm: "), "{e}");
        let e = fit_sum_of_gaussians(|_| [f64::NAN, 0.0, 0.0], 3, 8.0).unwrap_err();
        assert!(e.to_string().starts_with("profile: "), "{e}");
    }
}
