#include "supernodal_cholesky.hpp"

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <atomic>
#include <thread>
#include <stdexcept>

#include "dense_kernels.hpp"

namespace demnerf::mechanics {
namespace {

// Eigen's symbolic analysis with its elimination tree and column counts exposed: `below(j)` is the
// number of entries of L's column j under the diagonal.
struct EliminationTree : Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> {
  const Eigen::VectorXi& parent() const { return this->m_parent; }
  const Eigen::VectorXi& below() const { return this->m_nonZerosPerCol; }
};

}  // namespace

double SupernodalCholesky::analyse(const Eigen::SparseMatrix<double>& lower) {
  n_ = lower.rows();
  EliminationTree tree;
  tree.analyzePattern(lower);
  buildSupernodes(tree.parent(), tree.below());
  buildStructures(lower, tree.parent());
  for (long s = 0; s < supernodes(); ++s) {
    const int width = first_[s + 1] - first_[s];
    if (static_cast<int>(rows_[s].size()) != width + tree.below()(first_[s + 1] - 1))
      throw std::logic_error("supernodal Cholesky: a supernode's structure disagrees with the column counts");
  }
  panels_.assign(first_.size() - 1, Eigen::MatrixXd());
  splitSubtrees();
  return tree.below().cast<double>().squaredNorm();
}

// Fundamental supernodes: column j + 1 joins column j's supernode when it is j's parent, its only
// child, and its structure is j's without j itself. A grid node's three components always join.
void SupernodalCholesky::buildSupernodes(const Eigen::VectorXi& parent, const Eigen::VectorXi& below) {
  std::vector<int> child_count(n_, 0);
  for (Eigen::Index j = 0; j < n_; ++j)
    if (parent(j) >= 0) ++child_count[parent(j)];
  first_.assign(1, 0);
  for (Eigen::Index j = 1; j < n_; ++j) {
    const bool joins = parent(j - 1) == j && child_count[j] == 1 && below(j - 1) == below(j) + 1;
    if (!joins) first_.push_back(static_cast<int>(j));
  }
  if (n_ > 0) first_.push_back(static_cast<int>(n_));
  else first_.assign(1, 0);
}

// Each supernode's rows: its own columns, then the union of A's entries below them and of its
// children's rows below their columns. Children come before parents in column order.
void SupernodalCholesky::buildStructures(const Eigen::SparseMatrix<double>& lower, const Eigen::VectorXi& parent) {
  const long count = supernodes();
  std::vector<int> owner(n_);
  for (long s = 0; s < count; ++s)
    for (int j = first_[s]; j < first_[s + 1]; ++j) owner[j] = static_cast<int>(s);
  children_.assign(count, {});
  parent_.clear();
  rows_.assign(count, {});
  std::vector<long> mark(n_, -1);
  for (long s = 0; s < count; ++s) {
    const int f = first_[s], l = first_[s + 1] - 1;
    parent_.push_back(parent(l) >= 0 ? owner[parent(l)] : -1);
    if (parent(l) >= 0) children_[owner[parent(l)]].push_back(s);
    std::vector<int>& rows = rows_[s];
    for (int j = f; j <= l; ++j) rows.push_back(j);
    const auto add = [&](int i) {
      if (i > l && mark[i] != s) {
        mark[i] = s;
        rows.push_back(i);
      }
    };
    for (int j = f; j <= l; ++j)
      for (Eigen::SparseMatrix<double>::InnerIterator it(lower, j); it; ++it) add(static_cast<int>(it.row()));
    for (long c : children_[s])
      for (int i : rows_[c]) add(i);
    std::sort(rows.begin() + (l - f + 1), rows.end());
  }
}

double SupernodalCholesky::storedEntries() const {
  double sum = 0.0;
  for (const auto& p : panels_) sum += static_cast<double>(p.size());
  return sum;
}

// Subtrees for the threads: starting from the roots, the heaviest subtree is opened (it joins the
// part factorised after the threads, its children become candidates) while it outweighs the rest,
// then the candidates are dealt largest first to the least loaded thread.
void SupernodalCholesky::splitSubtrees() {
  const long count = supernodes();
  std::vector<double> work(count, 0.0);
  for (long s = 0; s < count; ++s) {
    const double m = static_cast<double>(rows_[s].size()), w = first_[s + 1] - first_[s];
    work[s] += w * m * m;
    if (parent_[s] >= 0) work[parent_[s]] += work[s];
  }
  group_.assign(count, -1);
  std::vector<long> candidates;
  for (long s = 0; s < count; ++s)
    if (parent_[s] < 0) candidates.push_back(s);
  std::vector<char> opened(count, 0);
  for (int round = 0; round < 64 && !candidates.empty(); ++round) {
    const auto heaviest = std::max_element(candidates.begin(), candidates.end(), [&](long a, long b) { return work[a] < work[b]; });
    double rest = 0.0;
    for (long c : candidates) rest += c == *heaviest ? 0.0 : work[c];
    if (work[*heaviest] <= rest || children_[*heaviest].empty()) break;
    const long top = *heaviest;
    opened[top] = 1;
    candidates.erase(heaviest);
    candidates.insert(candidates.end(), children_[top].begin(), children_[top].end());
  }
  std::sort(candidates.begin(), candidates.end(), [&](long a, long b) { return work[a] > work[b]; });
  std::vector<double> load(threads_, 0.0);
  for (long c : candidates) {
    const long t = std::min_element(load.begin(), load.end()) - load.begin();
    group_[c] = static_cast<int>(t);
    load[t] += work[c];
  }
  for (long s = count - 1; s >= 0; --s)  // parents come after their children
    if (!opened[s] && group_[s] < 0 && parent_[s] >= 0) group_[s] = group_[parent_[s]];
}

bool SupernodalCholesky::factorise(const Eigen::SparseMatrix<double>& lower) {
  if (lower.rows() != n_ || lower.cols() != n_) throw std::logic_error("supernodal Cholesky: factorise() before analyse()");
  std::vector<Eigen::MatrixXd> updates(first_.size() - 1);
  std::atomic<bool> failed{false};
  // Group g's supernodes in column order (children first); g = -1 after the threads' subtrees.
  const auto run = [&](int g) {
    std::vector<int> position(n_, -1);
    std::vector<double> front;  // reused: a fresh front per supernode cost a page fault per 4 kB
    for (long s = 0; s < supernodes() && !failed; ++s)
      if (group_[s] == g && !factoriseSupernode(lower, s, updates, position, front)) failed = true;
  };
  std::vector<std::thread> pool;
  for (int g = 1; g < threads_; ++g) pool.emplace_back(run, g);
  run(0);
  for (auto& t : pool) t.join();
  if (!failed) run(-1);
  return !failed;
}

// The front of supernode s: A's columns and the children's updates (extend-add), its dense
// Cholesky, the panel below and the Schur complement it passes to its parent.
bool SupernodalCholesky::factoriseSupernode(const Eigen::SparseMatrix<double>& lower, long s,
                                            std::vector<Eigen::MatrixXd>& updates, std::vector<int>& position,
                                            std::vector<double>& front_buffer) {
  const int f = first_[s], w = first_[s + 1] - f;
  const std::vector<int>& rows = rows_[s];
  const int m = static_cast<int>(rows.size());
  for (int i = 0; i < m; ++i) position[rows[i]] = i;
  if (front_buffer.size() < static_cast<std::size_t>(m) * m) front_buffer.resize(static_cast<std::size_t>(m) * m);
  Eigen::Map<Eigen::MatrixXd> front(front_buffer.data(), m, m);
  front.setZero();
  for (int j = f; j < f + w; ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(lower, j); it; ++it) front(position[it.row()], j - f) += it.value();
  std::vector<int> to;
  for (long c : children_[s]) {
    const std::vector<int>& child_rows = rows_[c];
    const int wc = first_[c + 1] - first_[c], mu = static_cast<int>(child_rows.size()) - wc;
    to.resize(mu);
    for (int a = 0; a < mu; ++a) to[a] = position[child_rows[wc + a]];
    const Eigen::MatrixXd& U = updates[c];
    for (int b = 0; b < mu; ++b)
      for (int a = b; a < mu; ++a) front(to[a], to[b]) += U(a, b);
    updates[c] = Eigen::MatrixXd();
  }
  // L11, L21 L11^T = A21 and the Schur complement, in place (dense_kernels.hpp: this CPU's code).
  if (!dense::factorFront(front.data(), m, w)) return false;
  panels_[s] = front.leftCols(w);
  if (m > w) updates[s] = front.bottomRightCorner(m - w, m - w);
  return true;
}

Eigen::VectorXd SupernodalCholesky::solve(const Eigen::VectorXd& b) const {
  Eigen::VectorXd y = b, part;
  const long count = supernodes();
  for (long s = 0; s < count; ++s) {  // L y = b
    const int f = first_[s], w = first_[s + 1] - f, m = static_cast<int>(rows_[s].size());
    const Eigen::MatrixXd& panel = panels_[s];
    part.resize(m - w);
    dense::panelForward(panel.data(), m, w, y.data() + f, part.data());
    for (int i = 0; i < m - w; ++i) y(rows_[s][w + i]) -= part(i);
  }
  for (long s = count - 1; s >= 0; --s) {  // L^T x = y
    const int f = first_[s], w = first_[s + 1] - f, m = static_cast<int>(rows_[s].size());
    const Eigen::MatrixXd& panel = panels_[s];
    part.resize(m - w);
    for (int i = 0; i < m - w; ++i) part(i) = y(rows_[s][w + i]);
    dense::panelBackward(panel.data(), m, w, part.data(), y.data() + f);
  }
  return y;
}

}  // namespace demnerf::mechanics
