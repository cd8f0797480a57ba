//! Square matrices for the adding-doubling operators.

/// A square matrix, row-major. The operators here are 32 x 32; two products and a solve are
/// all this needs, not worth a linear-algebra dependency.
#[derive(Clone, Debug)]
pub(super) struct Mat {
    n: usize,
    pub(super) a: Vec<f64>,
}

impl Mat {
    pub(super) fn zeros(n: usize) -> Self {
        Self {
            n,
            a: vec![0.0; n * n],
        }
    }
    pub(super) fn identity(n: usize) -> Self {
        let mut m = Self::zeros(n);
        for i in 0..n {
            m.a[i * n + i] = 1.0;
        }
        m
    }
    pub(super) fn at(&self, i: usize, j: usize) -> f64 {
        self.a[i * self.n + j]
    }
    pub(super) fn mul(&self, b: &Mat) -> Mat {
        let n = self.n;
        let mut c = Mat::zeros(n);
        for i in 0..n {
            for k in 0..n {
                let x = self.a[i * n + k];
                if x != 0.0 {
                    for j in 0..n {
                        c.a[i * n + j] += x * b.a[k * n + j];
                    }
                }
            }
        }
        c
    }
    pub(super) fn mul_vec(&self, v: &[f64]) -> Vec<f64> {
        (0..self.n)
            .map(|i| (0..self.n).map(|j| self.a[i * self.n + j] * v[j]).sum())
            .collect()
    }
    pub(super) fn add(&self, b: &Mat) -> Mat {
        Mat {
            n: self.n,
            a: self.a.iter().zip(&b.a).map(|(x, y)| x + y).collect(),
        }
    }
    pub(super) fn sub(&self, b: &Mat) -> Mat {
        Mat {
            n: self.n,
            a: self.a.iter().zip(&b.a).map(|(x, y)| x - y).collect(),
        }
    }
    /// `self^-1 b` for a matrix right-hand side, by LU with partial pivoting. The matrices
    /// solved here are `I - R R'` with `R R'` a contraction (light that bounces between two
    /// layers loses some at every bounce), so they are well conditioned.
    pub(super) fn solve(&self, b: &Mat) -> Mat {
        let n = self.n;
        let mut lu = self.a.clone();
        let mut x = b.a.clone();
        let cols = b.n;
        for k in 0..n {
            let p = (k..n)
                .max_by(|&i, &j| lu[i * n + k].abs().total_cmp(&lu[j * n + k].abs()))
                .expect("k < n");
            if p != k {
                for j in 0..n {
                    lu.swap(k * n + j, p * n + j);
                }
                for j in 0..cols {
                    x.swap(k * cols + j, p * cols + j);
                }
            }
            let d = lu[k * n + k];
            for i in k + 1..n {
                let f = lu[i * n + k] / d;
                if f != 0.0 {
                    for j in k..n {
                        lu[i * n + j] -= f * lu[k * n + j];
                    }
                    for j in 0..cols {
                        x[i * cols + j] -= f * x[k * cols + j];
                    }
                }
            }
        }
        for k in (0..n).rev() {
            let d = lu[k * n + k];
            for j in 0..cols {
                let mut s = x[k * cols + j];
                for i in k + 1..n {
                    s -= lu[k * n + i] * x[i * cols + j];
                }
                x[k * cols + j] = s / d;
            }
        }
        Mat { n, a: x }
    }
    pub(super) fn solve_vec(&self, v: &[f64]) -> Vec<f64> {
        let mut b = Mat::zeros(self.n);
        for i in 0..self.n {
            b.a[i * self.n] = v[i];
        }
        let x = self.solve(&b);
        (0..self.n).map(|i| x.a[i * self.n]).collect()
    }
}
