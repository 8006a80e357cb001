#pragma once
// The grid Newton's dense kernels: a supernodal front's Cholesky, panel and Schur complement
// (supernodal_cholesky.cpp) and a cell's stiffness products (grid_field_energy.cpp). Private to
// packages/mechanics/src.
//
// Why a separate TU with raw pointers: these are most of a T-bar solve's floating-point work, and
// built for this machine's CPU (DEMNERF_MECHANICS_NATIVE: AVX-512 on the development machine) the
// blocked dense products run 2-3x faster than the library's baseline x86-64 build. The TU's Eigen
// lives in a namespace of its own (dense_kernels.cpp), so no Eigen type or inline function crosses
// between code built with different flags: the interface holds no Eigen type.

namespace demnerf::mechanics::dense {

/// `front`: m x m, column-major, its lower triangle holding a supernode's front. On return its top
/// left w x w lower triangle is L11 (A11 = L11 L11^T), its bottom left (m - w) x w is
/// L21 = A21 L11^-T, and the lower triangle of its bottom right the Schur complement
/// A22 - L21 L21^T. False when A11 is not positive definite (the front is then unusable).
bool factorFront(double* front, int m, int w);

/// A supernode's share of the forward solve L y = b: y1 (its w columns) <- L11^-1 y1, and
/// part = L21 y1 (m - w values, subtracted from the rows below by the caller). panel: m x w.
void panelForward(const double* panel, int m, int w, double* y1, double* part);
/// Its share of L^T x = y: y1 <- L11^-T (y1 - L21^T part), part the rows below's values.
void panelBackward(const double* panel, int m, int w, const double* part, double* y1);

/// A cell's stiffness by component pair, K_ij = sum_k G_i,k A_k,ij G_j,k^T for i >= j. G[i]: S x 3n
/// column-major (column 3 k + a: d phi_(s,i) / dX_a at point k); tangents: n column-major 9 x 9
/// tangents, row 3 i + a and column 3 j + b = dP_ia / dF_jb (volume-weighted); scratch: 3n x S
/// doubles; K[i (i + 1) / 2 + j]: S x S column-major outputs.
void cellStiffness(const double* const G[3], const double* tangents, long n, int S, double* scratch,
                   double* const K[6]);

/// A cut cell's blocks through its rows of the extension: out = E^T K E, with E S x r, K S x S and
/// out r x r (column-major); scratch: S x r doubles.
void reduceBlock(const double* E, int S, int r, const double* K, double* scratch, double* out);

}  // namespace demnerf::mechanics::dense
