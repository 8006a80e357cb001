#include "displacement_mlp.hpp"

#include <cmath>

namespace demnerf::mechanics {

using torch::Tensor;

const long DisplacementMlp::kPairK[6] = {0, 0, 0, 1, 1, 2};
const long DisplacementMlp::kPairM[6] = {0, 1, 2, 1, 2, 2};
const long DisplacementMlp::kSlotOf[9] = {0, 1, 2, 1, 3, 4, 2, 4, 5};

namespace {

// Derivative slots [n, k, in] times W' ([out, in] row-major) as one [n k, in] x [in, out] product.
// torch::matmul runs this as a batch of n products of k x in matrices when the operand requires
// grad (and so does its backward): on Beam3D's 1,512 particles that batch was a third of each
// training step.
Tensor slotsTimes(const Tensor& d, const Tensor& W) {
  return torch::mm(d.reshape({-1, d.size(2)}), W.t()).view({d.size(0), d.size(1), W.size(0)});
}

}  // namespace

DisplacementMlp::DisplacementMlp(int extra_inputs, int width, int depth, const std::string& activation,
                                 const Eigen::Vector3d& center, const Eigen::Vector3d& half, torch::Dtype dtype,
                                 double first_layer_scale)
    : activation_(activation) {
  const auto options = torch::TensorOptions().dtype(dtype);
  center_ = torch_support::toTensor(std::vector<Eigen::Vector3d>{center}, dtype);
  inv_half_ = torch_support::toTensor(std::vector<Eigen::Vector3d>{half.cwiseInverse()}, dtype).squeeze(0);
  pair_k_ = torch::from_blob(const_cast<long*>(kPairK), {6}, torch::kLong).clone();
  pair_m_ = torch::from_blob(const_cast<long*>(kPairM), {6}, torch::kLong).clone();
  int in = 3 + extra_inputs;
  for (int l = 0; l <= depth; ++l) {
    const int out = l == depth ? 3 : width;
    const double bound = std::sqrt(6.0 / (in + out)) * (l == 0 ? first_layer_scale : 1.0);
    Tensor W = (torch::rand({out, in}, options) * 2 - 1) * bound;
    if (l == depth) W.zero_();
    weights_.push_back(W.requires_grad_(true));
    biases_.push_back(torch::zeros({out}, options).requires_grad_(true));
    in = out;
  }
}

void DisplacementMlp::activate(const Tensor& a, Tensor& h, Tensor& s1, Tensor* s2) const {
  if (activation_ == "sin") {
    h = torch::sin(a);
    s1 = torch::cos(a);
    if (s2) *s2 = -h;
  } else if (activation_ == "softplus") {
    h = torch::softplus(a);
    s1 = torch::sigmoid(a);
    if (s2) *s2 = s1 * (1 - s1);
  } else if (activation_ == "sigmoid") {
    h = torch::sigmoid(a);
    s1 = h * (1 - h);
    if (s2) *s2 = s1 * (1 - 2 * h);
  } else {
    h = torch::tanh(a);
    s1 = 1 - h * h;
    if (s2) *s2 = -2 * h * s1;
  }
}

DisplacementMlp::Output DisplacementMlp::hidden(const Tensor& x, const Tensor& extra, int order) const {
  Tensor h = (x - center_) * inv_half_, dh, d2h;
  if (extra.defined()) h = torch::cat({h, extra}, 1);
  for (std::size_t l = 0; l + 1 < weights_.size(); ++l) {
    const Tensor a = torch::addmm(biases_[l], h, weights_[l].t());
    Tensor da, d2a;
    if (order >= 1) {
      // The first layer's X-derivative is constant: W's coordinate columns over the half extent.
      da = l == 0 ? (weights_[0].narrow(1, 0, 3).t() * inv_half_.unsqueeze(1))
                        .unsqueeze(0)
                        .expand({x.size(0), 3, weights_[0].size(0)})
                  : slotsTimes(dh, weights_[l]);
      if (order >= 2 && l > 0) d2a = slotsTimes(d2h, weights_[l]);
    }
    Tensor s1, s2;
    activate(a, h, s1, order >= 2 ? &s2 : nullptr);
    if (order >= 2) {
      d2h = s2.unsqueeze(1) * da.index_select(1, pair_k_) * da.index_select(1, pair_m_);
      if (l > 0) d2h = d2h + s1.unsqueeze(1) * d2a;
    }
    if (order >= 1) dh = s1.unsqueeze(1) * da;
  }
  return {h, dh, d2h};
}

DisplacementMlp::Output DisplacementMlp::forward(const Tensor& x, const Tensor& extra, int order) const {
  const Output o = hidden(x, extra, order);
  const Tensor& W = weights_.back();
  return {torch::addmm(biases_.back(), o.value, W.t()), order >= 1 ? slotsTimes(o.d1, W) : Tensor(),
          order >= 2 ? slotsTimes(o.d2, W) : Tensor()};
}

std::vector<Tensor> DisplacementMlp::parameters() const {
  std::vector<Tensor> p;
  for (std::size_t l = 0; l < weights_.size(); ++l) {
    p.push_back(weights_[l]);
    p.push_back(biases_[l]);
  }
  return p;
}

}  // namespace demnerf::mechanics
