//! Levenberg–Marquardt for the fit's small dense problems: forward-difference Jacobian, Cholesky
//! on the damped normal equations, damping lowered after a good step and raised after a bad one.

pub struct Solution {
    pub params: Vec<f64>,
    pub iterations: usize,
    /// Σ r² at `params`.
    pub cost: f64,
}

/// Minimises Σ r(p)² from `p`; `steps` are the finite-difference steps per parameter.
pub fn minimise(
    mut p: Vec<f64>,
    steps: &[f64],
    max_iterations: usize,
    mut residuals: impl FnMut(&[f64], &mut Vec<f64>),
) -> Solution {
    let n = p.len();
    let (mut r, mut r_step) = (Vec::new(), Vec::new());
    residuals(&p, &mut r);
    let mut cost: f64 = r.iter().map(|x| x * x).sum();
    let mut mu = 1e-3;
    let mut jac = vec![0.0f64; r.len() * n];
    let mut iterations = 0;
    for _ in 0..max_iterations {
        iterations += 1;
        for c in 0..n {
            let mut q = p.clone();
            q[c] += steps[c];
            residuals(&q, &mut r_step);
            for (row, (a, b)) in r_step.iter().zip(&r).enumerate() {
                jac[row * n + c] = (a - b) / steps[c];
            }
        }
        let (jtj, jtr) = normal_equations(&jac, &r, n);
        let mut improved = false;
        for _ in 0..10 {
            let mut a = jtj.clone();
            for i in 0..n {
                a[i * n + i] += mu * jtj[i * n + i].max(1e-9);
            }
            let Some(delta) = solve(a, jtr.iter().map(|x| -x).collect(), n) else {
                mu *= 10.0;
                continue;
            };
            let q: Vec<f64> = p.iter().zip(&delta).map(|(a, d)| a + d).collect();
            residuals(&q, &mut r_step);
            let new_cost: f64 = r_step.iter().map(|x| x * x).sum();
            if new_cost < cost {
                let gain = (cost - new_cost) / cost.max(1e-12);
                p = q;
                std::mem::swap(&mut r, &mut r_step);
                cost = new_cost;
                mu = (mu / 3.0).max(1e-9);
                improved = gain > 1e-7;
                break;
            }
            mu *= 4.0;
        }
        if !improved {
            break;
        }
    }
    Solution {
        params: p,
        iterations,
        cost,
    }
}

/// JᵀJ and Jᵀr of a row-major `rows × n` Jacobian.
fn normal_equations(jac: &[f64], r: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut jtj = vec![0.0; n * n];
    let mut jtr = vec![0.0; n];
    for (row, &ri) in jac.chunks_exact(n).zip(r) {
        for i in 0..n {
            if row[i] == 0.0 {
                continue;
            }
            jtr[i] += row[i] * ri;
            for j in 0..n {
                jtj[i * n + j] += row[i] * row[j];
            }
        }
    }
    (jtj, jtr)
}

/// Solves the symmetric positive definite system `a·x = b` by Cholesky; `None` if it is not.
fn solve(mut a: Vec<f64>, mut b: Vec<f64>, n: usize) -> Option<Vec<f64>> {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    for i in 0..n {
        let s: f64 = (0..i).map(|k| a[i * n + k] * b[k]).sum();
        b[i] = (b[i] - s) / a[i * n + i];
    }
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|k| a[k * n + i] * b[k]).sum();
        b[i] = (b[i] - s) / a[i * n + i];
    }
    Some(b)
}
