//! The mass matrix `M(q)` ([`MassMatrix`]), and its `M = L D Lᵀ` factorisation, kept with the
//! reciprocals of its pivots. The type stands here, below the general dynamics and the
//! yaw–pitch closed form, which both build it.
//!
//! Forward dynamics solves `M q̈ = b` several times per integration step. nalgebra's Cholesky
//! solve divides by each diagonal entry of `L` in turn, and those divisions form one serial
//! chain of `2N` divisions (≈ 14 cycles each), which made the solve cost more than the
//! CRBA that builds `M` (measured: 14.7 % of a simulated step). Here the factorisation takes
//! one reciprocal per pivot, so a solve is only multiplications and additions:
//! `y = L⁻¹ b` (unit lower triangle), `z = D⁻¹ y`, `x = L⁻ᵀ z`.
//!
//! `L` has a unit diagonal and `D = diag(d_j)`, with (column by column)
//! `d_j = M_jj − Σ_{k<j} L_jk² d_k` and `L_ij = (M_ij − Σ_{k<j} L_ik L_jk d_k) / d_j` for `i > j`.
//! In exact arithmetic `M` is symmetric positive definite exactly when every `d_j > 0`; this is
//! what [`MassMatrixFactor::new`] checks. In floating point, a matrix within rounding of
//! singular may come out with a tiny positive pivot (as with any Cholesky), and a pivot below
//! ~5.6·10⁻³⁰⁹ (whose reciprocal overflows) is rejected; mass matrices are nowhere near either.
//! Square-root free, so `L √D` is the Cholesky factor.

use super::model::JointVector;
use nalgebra::SMatrix;

/// `M(q)`, kg·m² (N·m·s²/rad).
pub type MassMatrix<const N: usize> = SMatrix<f64, N, N>;

/// `L D Lᵀ` factor of a symmetric positive-definite `N × N` matrix, on the stack.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassMatrixFactor<const N: usize> {
    /// `L`, unit lower triangular; only the entries below the diagonal are read.
    lower: [[f64; N]; N],
    /// `d_j`.
    pivot: [f64; N],
    /// `1 / d_j`.
    inverse_pivot: [f64; N],
}

impl<const N: usize> MassMatrixFactor<N> {
    /// Factorises `matrix` (only its lower triangle is read). `None` when it is not positive
    /// definite, including when an entry is NaN.
    #[inline]
    pub fn new(matrix: &MassMatrix<N>) -> Option<Self> {
        let mut lower = [[0.0; N]; N];
        let mut pivot = [0.0; N];
        let mut inverse_pivot = [0.0; N];
        for j in 0..N {
            // L_jk d_k for k < j, used by the whole column j.
            let mut scaled_row = [0.0; N];
            let mut d = matrix[(j, j)];
            for k in 0..j {
                scaled_row[k] = lower[j][k] * pivot[k];
                d -= lower[j][k] * scaled_row[k];
            }
            // Rejects NaN as well as d ≤ 0 (and d so small that 1/d overflows).
            let inverse = 1.0 / d;
            if d.is_nan() || d <= 0.0 || inverse.is_infinite() {
                return None;
            }
            pivot[j] = d;
            inverse_pivot[j] = inverse;
            for i in j + 1..N {
                let mut entry = matrix[(i, j)];
                for k in 0..j {
                    entry -= lower[i][k] * scaled_row[k];
                }
                lower[i][j] = entry * inverse_pivot[j];
            }
        }
        Some(Self { lower, pivot, inverse_pivot })
    }

    /// The factor of the identity matrix (`L = D = E`), a placeholder before the first
    /// factorisation; equal to `MassMatrixFactor::new(&MassMatrix::identity())`.
    pub fn identity() -> Self {
        Self { lower: [[0.0; N]; N], pivot: [1.0; N], inverse_pivot: [1.0; N] }
    }

    /// A factor whose every solve is NaN: what a scratch keeps after a failed factorisation,
    /// so that using it anyway cannot pass for a result.
    pub(crate) fn unusable() -> Self {
        Self { lower: [[0.0; N]; N], pivot: [f64::NAN; N], inverse_pivot: [f64::NAN; N] }
    }

    /// `x = M⁻¹ b`.
    #[inline]
    pub fn solve(&self, b: &JointVector<N>) -> JointVector<N> {
        let mut x = *b;
        for i in 0..N {
            for k in 0..i {
                x[i] -= self.lower[i][k] * x[k];
            }
        }
        for i in 0..N {
            x[i] *= self.inverse_pivot[i];
        }
        for i in (0..N).rev() {
            for k in i + 1..N {
                x[i] -= self.lower[k][i] * x[k];
            }
        }
        x
    }

    /// The pivots `d_j` of `D`, all > 0; their product is `det M`.
    pub fn pivots(&self) -> JointVector<N> {
        JointVector::from(self.pivot)
    }

    /// `M` rebuilt from the factor, `L D Lᵀ` (for checks).
    pub fn reconstruct(&self) -> MassMatrix<N> {
        let unit_lower = MassMatrix::<N>::from_fn(|i, k| match i.cmp(&k) {
            std::cmp::Ordering::Greater => self.lower[i][k],
            std::cmp::Ordering::Equal => 1.0,
            std::cmp::Ordering::Less => 0.0,
        });
        unit_lower * MassMatrix::<N>::from_diagonal(&self.pivots()) * unit_lower.transpose()
    }
}
