#include "gyrotc/algorithms/fit/bp_network_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace gyrotc::fit {

namespace {

// splitmix64: a small generator with a fixed, portable output sequence.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  // Uniform in [-1, 1).
  double symmetric() { return 2.0 * static_cast<double>(next() >> 11) * 0x1.0p-53 - 1.0; }

 private:
  std::uint64_t state_;
};

// Network with its parameters in one flat vector: per layer the row-major
// weights then the biases.
class Net {
 public:
  explicit Net(const std::vector<int>& hidden) {
    int in = 1;
    for (int h : hidden) {
      shape_.push_back({in, h});
      in = h;
    }
    shape_.push_back({in, 1});
    std::size_t count = 0;
    for (const auto& [i, o] : shape_) count += static_cast<std::size_t>((i + 1) * o);
    theta_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(count));
    std::size_t widest = 1;
    for (const auto& s : shape_) widest = std::max(widest, static_cast<std::size_t>(s.second));
    act_.assign(shape_.size() + 1, std::vector<double>(widest));
    delta_.assign(2, std::vector<double>(widest));
  }

  Eigen::VectorXd& theta() { return theta_; }
  Eigen::Index size() const { return theta_.size(); }

  // Nguyen-Widrow style start for tansig layers, small weights on the output.
  void initialise(Random& rng) {
    Eigen::Index p = 0;
    for (std::size_t l = 0; l < shape_.size(); ++l) {
      const auto [in, out] = shape_[l];
      const bool output = l + 1 == shape_.size();
      const double beta = output ? 1.0 / std::sqrt(static_cast<double>(in))
                                 : 0.7 * std::pow(static_cast<double>(out), 1.0 / static_cast<double>(in));
      for (int o = 0; o < out; ++o) {
        double norm = 0.0;
        const Eigen::Index row = p + o * in;
        for (int i = 0; i < in; ++i) {
          theta_(row + i) = rng.symmetric();
          norm += theta_(row + i) * theta_(row + i);
        }
        const double scale = output ? beta : beta / std::max(std::sqrt(norm), 1e-12);
        for (int i = 0; i < in; ++i) theta_(row + i) *= scale;
      }
      p += in * out;
      for (int o = 0; o < out; ++o) theta_(p + o) = output ? 0.0 : beta * rng.symmetric();
      p += out;
    }
  }

  double forward(const Eigen::VectorXd& theta, double x) {
    act_[0][0] = x;
    Eigen::Index p = 0;
    for (std::size_t l = 0; l < shape_.size(); ++l) {
      const auto [in, out] = shape_[l];
      const bool output = l + 1 == shape_.size();
      for (int o = 0; o < out; ++o) {
        double s = theta(p + in * out + o);
        for (int i = 0; i < in; ++i) s += theta(p + o * in + i) * act_[l][static_cast<std::size_t>(i)];
        act_[l + 1][static_cast<std::size_t>(o)] = output ? s : tansig(s);
      }
      p += (in + 1) * out;
    }
    return act_.back()[0];
  }

  // d(output)/d(theta) at x, written into row `r` of jac.
  void gradient(double x, Eigen::MatrixXd& jac, Eigen::Index r) {
    forward(theta_, x);
    Eigen::Index end = theta_.size();
    std::vector<double>* delta = &delta_[0];
    std::vector<double>* below = &delta_[1];
    (*delta)[0] = 1.0;  // linear output
    for (std::size_t l = shape_.size(); l-- > 0;) {
      const auto [in, out] = shape_[l];
      const Eigen::Index p = end - (in + 1) * out;
      for (int o = 0; o < out; ++o) {
        const double d = (*delta)[static_cast<std::size_t>(o)];
        jac(r, p + in * out + o) = d;
        for (int i = 0; i < in; ++i) jac(r, p + o * in + i) = d * act_[l][static_cast<std::size_t>(i)];
      }
      if (l > 0) {
        for (int i = 0; i < in; ++i) {
          double s = 0.0;
          for (int o = 0; o < out; ++o) s += theta_(p + o * in + i) * (*delta)[static_cast<std::size_t>(o)];
          const double a = act_[l][static_cast<std::size_t>(i)];
          (*below)[static_cast<std::size_t>(i)] = s * (1.0 - a * a);  // tansig'
        }
        std::swap(delta, below);
      }
      end = p;
    }
  }

  std::vector<NetworkLayer> layers(const Eigen::VectorXd& theta) const {
    std::vector<NetworkLayer> out;
    Eigen::Index p = 0;
    for (const auto& [in, o] : shape_) {
      NetworkLayer layer;
      layer.inputs = in;
      layer.outputs = o;
      layer.weights.assign(theta.data() + p, theta.data() + p + in * o);
      p += in * o;
      layer.biases.assign(theta.data() + p, theta.data() + p + o);
      p += o;
      out.push_back(std::move(layer));
    }
    return out;
  }

 private:
  std::vector<std::pair<int, int>> shape_;  // (inputs, outputs) per layer
  Eigen::VectorXd theta_;
  std::vector<std::vector<double>> act_;
  std::vector<std::vector<double>> delta_;
};

double mse(Net& net, const Eigen::VectorXd& theta, const std::vector<double>& x, const std::vector<double>& y) {
  if (x.empty()) return 0.0;
  double s = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double e = y[i] - net.forward(theta, x[i]);
    s += e * e;
  }
  return s / static_cast<double>(x.size());
}

void check_options(const BpTrainOptions& o) {
  if (o.hidden.empty()) throw std::invalid_argument("bp network: need at least one hidden layer");
  for (int h : o.hidden) {
    if (h < 1 || h > BpNetwork::kMaxWidth) {
      throw std::invalid_argument("bp network: hidden layer sizes must be 1.." + std::to_string(BpNetwork::kMaxWidth));
    }
  }
  if (o.restarts < 1) throw std::invalid_argument("bp network: restarts must be >= 1");
  if (o.max_epochs < 1) throw std::invalid_argument("bp network: max_epochs must be >= 1");
  if (!(o.validation_fraction >= 0.0 && o.validation_fraction < 0.5)) {
    throw std::invalid_argument("bp network: validation_fraction must be in [0, 0.5)");
  }
  if (!(o.mu_initial > 0.0 && o.mu_decrease > 0.0 && o.mu_decrease < 1.0 && o.mu_increase > 1.0)) {
    throw std::invalid_argument("bp network: bad mu settings");
  }
}

// One Levenberg-Marquardt training: initial weights from init_seed, the
// validation split from split_seed (the same split for every restart, so
// that their held-out errors compare).
BpTrainResult train_once(std::span<const double> temp_c, std::span<const double> value,
                         const BpTrainOptions& options, std::uint64_t split_seed, std::uint64_t init_seed,
                         double t_min_c, double t_max_c) {
  const std::size_t n = temp_c.size();
  if (n < 3 || value.size() != n) throw std::invalid_argument("bp network: need at least 3 points");
  if (!(t_min_c < t_max_c)) {
    const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
    t_min_c = *lo;
    t_max_c = *hi;
  }
  const auto [vlo, vhi] = std::minmax_element(value.begin(), value.end());
  BpNetwork result_net;
  result_net.t_min_c = t_min_c;
  result_net.t_max_c = t_max_c;
  result_net.out_center_mv = 0.5 * (*vlo + *vhi);
  result_net.out_half_range_mv = *vhi > *vlo ? 0.5 * (*vhi - *vlo) : 1.0;

  Random rng(split_seed);
  // Validation split: interior points only, picked by a seeded shuffle.
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return temp_c[a] < temp_c[b]; });
  std::vector<std::size_t> interior(order.begin() + 1, order.end() - 1);
  for (std::size_t i = interior.size(); i > 1; --i) {
    std::swap(interior[i - 1], interior[static_cast<std::size_t>(rng.next() % i)]);
  }
  const auto held = std::min(interior.size(), static_cast<std::size_t>(std::lround(options.validation_fraction * static_cast<double>(n))));
  std::vector<bool> is_validation(n, false);
  for (std::size_t i = 0; i < held; ++i) is_validation[interior[i]] = true;
  std::vector<double> xt, yt, xv, yv;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = 2.0 * (temp_c[i] - t_min_c) / (t_max_c - t_min_c) - 1.0;
    const double y = (value[i] - result_net.out_center_mv) / result_net.out_half_range_mv;
    (is_validation[i] ? xv : xt).push_back(x);
    (is_validation[i] ? yv : yt).push_back(y);
  }

  Net net(options.hidden);
  Random init(init_seed);
  net.initialise(init);
  const auto m = static_cast<Eigen::Index>(xt.size());
  const Eigen::Index p = net.size();
  Eigen::MatrixXd jac(m, p);
  Eigen::VectorXd err(m);
  Eigen::VectorXd best = net.theta();
  double best_validation = held > 0 ? mse(net, net.theta(), xv, yv) : 0.0;
  double perf = mse(net, net.theta(), xt, yt);
  double mu = options.mu_initial;
  int fails = 0;
  BpTrainResult result;
  result.stop_reason = "max_epochs";
  for (int epoch = 1; epoch <= options.max_epochs; ++epoch) {
    result.epochs = epoch;
    for (Eigen::Index i = 0; i < m; ++i) {
      net.gradient(xt[static_cast<std::size_t>(i)], jac, i);
      err(i) = yt[static_cast<std::size_t>(i)] - net.forward(net.theta(), xt[static_cast<std::size_t>(i)]);
    }
    bool improved = false;
    while (mu <= options.mu_max) {
      // (J'J + mu I) d = J'e, solved in the smaller of the two dimensions.
      Eigen::VectorXd step;
      if (m < p) {
        Eigen::MatrixXd a = jac * jac.transpose();
        a.diagonal().array() += mu;
        step = jac.transpose() * a.ldlt().solve(err);
      } else {
        Eigen::MatrixXd a = jac.transpose() * jac;
        a.diagonal().array() += mu;
        step = a.ldlt().solve(jac.transpose() * err);
      }
      const Eigen::VectorXd trial = net.theta() + step;
      const double trial_perf = mse(net, trial, xt, yt);
      if (std::isfinite(trial_perf) && trial_perf < perf) {
        net.theta() = trial;
        perf = trial_perf;
        mu *= options.mu_decrease;
        improved = true;
        break;
      }
      mu *= options.mu_increase;
    }
    if (!improved) {
      result.stop_reason = "mu_max";
      break;
    }
    if (held > 0) {
      const double v = mse(net, net.theta(), xv, yv);
      if (v < best_validation) {
        best_validation = v;
        best = net.theta();
        fails = 0;
      } else if (++fails >= options.max_fail) {
        result.stop_reason = "validation";
        break;
      }
    } else {
      best = net.theta();
    }
    if (perf <= options.goal_mse) {
      result.stop_reason = "goal";
      break;
    }
  }
  result.seed_used = init_seed;
  result.train_mse = mse(net, best, xt, yt);
  result.validation_mse = held > 0 ? best_validation : 0.0;
  result.validation_points = held;
  result_net.layers = net.layers(best);
  result.net = std::move(result_net);
  return result;
}

}  // namespace

BpTrainResult train_bp_network(std::span<const double> temp_c, std::span<const double> value,
                               const BpTrainOptions& options, double t_min_c, double t_max_c) {
  check_options(options);
  BpTrainResult best;
  double best_error = std::numeric_limits<double>::infinity();
  Random seeds(options.seed);  // each restart draws its initial weights' seed from the user's
  for (int r = 0; r < options.restarts; ++r) {
    BpTrainResult trial = train_once(temp_c, value, options, options.seed, seeds.next(), t_min_c, t_max_c);
    // The held-out points judge the restarts; without a split, the training error.
    const double error = trial.validation_points > 0 ? trial.validation_mse : trial.train_mse;
    if (error < best_error) {
      best_error = error;
      best = std::move(trial);
    }
  }
  return best;
}

}  // namespace gyrotc::fit
