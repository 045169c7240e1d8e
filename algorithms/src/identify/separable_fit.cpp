#include "gyrotc/algorithms/identify/separable_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace gyrotc::identify {

Eigen::MatrixXd gram_matrix(const Eigen::MatrixXd& design) {
  const Eigen::Index n = design.rows();
  const Eigen::Index p = design.cols();
  const double* data = design.data();  // column-major
  std::vector<double> normal(static_cast<std::size_t>(p * p), 0.0);
  std::vector<Eigen::Index> nz(static_cast<std::size_t>(p));
  std::vector<double> val(static_cast<std::size_t>(p));
  for (Eigen::Index i = 0; i < n; ++i) {
    std::size_t count = 0;
    for (Eigen::Index j = 0; j < p; ++j) {
      const double v = data[j * n + i];
      if (v != 0.0) {
        nz[count] = j;
        val[count] = v;
        ++count;
      }
    }
    for (std::size_t a = 0; a < count; ++a) {
      double* row = normal.data() + nz[a] * p;
      for (std::size_t b = a; b < count; ++b) row[nz[b]] += val[a] * val[b];
    }
  }
  Eigen::MatrixXd out(p, p);
  for (Eigen::Index a = 0; a < p; ++a) {
    for (Eigen::Index b = a; b < p; ++b) {
      out(a, b) = out(b, a) = normal[static_cast<std::size_t>(a * p + b)];
    }
  }
  return out;
}

ScaledNormal scaled_normal(const Eigen::MatrixXd& design) {
  const Eigen::Index p = design.cols();
  Eigen::MatrixXd normal = gram_matrix(design);
  ScaledNormal out;
  out.scale.resize(p);
  for (Eigen::Index j = 0; j < p; ++j) {
    const double norm = std::sqrt(normal(j, j));
    out.scale(j) = norm > 0.0 ? 1.0 / norm : 1.0;
  }
  normal = out.scale.asDiagonal() * normal * out.scale.asDiagonal();
  normal.diagonal().array() += 1e-10;
  out.ldlt.compute(normal);
  return out;
}

double ScaledNormal::log_det() const {
  double out = 0.0;
  for (Eigen::Index j = 0; j < scale.size(); ++j) out -= 2.0 * std::log(scale(j));
  for (Eigen::Index j = 0; j < scale.size(); ++j) out += std::log(std::max(ldlt.vectorD()(j), 1e-300));
  return out;
}

namespace {

// (A^T A)^-1 in the scaled coordinates of scaled_normal.
Eigen::MatrixXd scaled_inverse_normal(const Eigen::MatrixXd& design, Eigen::VectorXd& scale) {
  ScaledNormal normal = scaled_normal(design);
  scale = std::move(normal.scale);
  const Eigen::Index p = design.cols();
  return normal.ldlt.solve(Eigen::MatrixXd::Identity(p, p));
}

struct Profile {
  Eigen::VectorXd beta;
  Eigen::VectorXd prediction;
  double sse = std::numeric_limits<double>::infinity();
};

Profile profile(const Eigen::VectorXd& y, const SeparableModel& model,
                const std::vector<double>& theta, Eigen::MatrixXd& design, Eigen::VectorXd& offset) {
  model.evaluate(theta, design, offset);
  Profile p;
  p.beta = design.cols() > 0 ? solve_linear(design, y - offset) : Eigen::VectorXd();
  p.prediction = design.cols() > 0 ? Eigen::VectorXd(offset + design * p.beta) : offset;
  p.sse = (y - p.prediction).squaredNorm();
  if (!std::isfinite(p.sse)) p.sse = std::numeric_limits<double>::infinity();
  return p;
}

std::vector<double> clamp_theta(std::vector<double> theta, const SeparableModel& model) {
  for (std::size_t j = 0; j < theta.size(); ++j) {
    theta[j] = std::clamp(theta[j], model.theta_lower[j], model.theta_upper[j]);
  }
  return theta;
}

}  // namespace

std::vector<std::vector<double>> grid_product(const std::vector<std::vector<double>>& axes) {
  std::vector<std::vector<double>> out{{}};
  for (const auto& axis : axes) {
    std::vector<std::vector<double>> next;
    for (const auto& prefix : out) {
      for (double v : axis) {
        auto p = prefix;
        p.push_back(v);
        next.push_back(std::move(p));
      }
    }
    out = std::move(next);
  }
  return out;
}

Eigen::VectorXd solve_linear(const Eigen::MatrixXd& design, const Eigen::VectorXd& y) {
  Eigen::VectorXd scale;
  const Eigen::MatrixXd inverse = scaled_inverse_normal(design, scale);
  const Eigen::VectorXd rhs = scale.asDiagonal() * (design.transpose() * y);
  return scale.asDiagonal() * (inverse * rhs);
}

SeparableFit fit_separable(const Eigen::VectorXd& y, const SeparableModel& model) {
  Eigen::MatrixXd design;
  Eigen::VectorXd offset;
  const std::size_t k = model.theta_lower.size();

  std::vector<double> theta;
  Profile best;
  if (k == 0) {
    best = profile(y, model, theta, design, offset);
  } else {
    for (const auto& start : model.theta_grid) {
      Profile p = profile(y, model, start, design, offset);
      if (p.sse < best.sse) {
        best = std::move(p);
        theta = start;
      }
    }
    // Levenberg-Marquardt on the projected residual y - prediction(theta).
    double lambda = 1e-3;
    for (int iter = 0; iter < 40; ++iter) {
      Eigen::MatrixXd jac(y.size(), static_cast<Eigen::Index>(k));
      for (std::size_t j = 0; j < k; ++j) {
        const double h = 1e-6 * (model.theta_upper[j] - model.theta_lower[j]);
        std::vector<double> stepped = theta;
        stepped[j] += (stepped[j] + h <= model.theta_upper[j]) ? h : -h;
        const double dh = stepped[j] - theta[j];
        const Profile p = profile(y, model, stepped, design, offset);
        jac.col(static_cast<Eigen::Index>(j)) = (p.prediction - best.prediction) / dh;
      }
      const Eigen::VectorXd residual = y - best.prediction;
      Eigen::MatrixXd normal = jac.transpose() * jac;
      const Eigen::VectorXd grad = jac.transpose() * residual;
      bool improved = false;
      for (int tries = 0; tries < 8 && !improved; ++tries) {
        Eigen::MatrixXd damped = normal;
        for (Eigen::Index j = 0; j < damped.rows(); ++j) {
          damped(j, j) += lambda * std::max(normal(j, j), 1e-12);
        }
        const Eigen::VectorXd step = damped.ldlt().solve(grad);
        std::vector<double> trial = theta;
        for (std::size_t j = 0; j < k; ++j) trial[j] += step(static_cast<Eigen::Index>(j));
        trial = clamp_theta(trial, model);
        Profile p = profile(y, model, trial, design, offset);
        if (p.sse < best.sse) {
          const double gain = (best.sse - p.sse) / std::max(best.sse, 1e-300);
          best = std::move(p);
          theta = trial;
          lambda = std::max(lambda / 4.0, 1e-9);
          improved = true;
          if (gain < 1e-7) iter = 1000;  // converged: a further gain would not change any decision
        } else {
          lambda *= 8.0;
        }
      }
      if (!improved) break;
    }
  }

  SeparableFit fit;
  fit.theta = theta;
  // Re-evaluate at the final theta for the design matrix of the covariance.
  const Profile final_profile = profile(y, model, theta, design, offset);
  fit.beta = final_profile.beta;
  fit.prediction = final_profile.prediction;
  fit.residual = y - fit.prediction;
  fit.sse = final_profile.sse;

  fit.covariance_unscaled = inverse_normal(model_jacobian(model, theta, fit.beta, &fit.theta_at_bound));
  return fit;
}

Eigen::MatrixXd model_jacobian(const SeparableModel& model, const std::vector<double>& theta,
                               const Eigen::VectorXd& beta, bool* at_bound) {
  Eigen::MatrixXd design;
  Eigen::VectorXd offset;
  model.evaluate(theta, design, offset);
  const Eigen::Index p = design.cols();
  const std::size_t k = theta.size();
  Eigen::VectorXd prediction = offset;
  if (p > 0) prediction += design * beta;
  Eigen::MatrixXd jac(design.rows(), p + static_cast<Eigen::Index>(k));
  if (p > 0) jac.leftCols(p) = design;
  if (at_bound) *at_bound = false;
  for (std::size_t j = 0; j < k; ++j) {
    const double range = model.theta_upper[j] - model.theta_lower[j];
    const double h = 1e-6 * range;
    std::vector<double> stepped = theta;
    stepped[j] += (stepped[j] + h <= model.theta_upper[j]) ? h : -h;
    const double dh = stepped[j] - theta[j];
    Eigen::MatrixXd design_h;
    Eigen::VectorXd offset_h;
    model.evaluate(stepped, design_h, offset_h);
    Eigen::VectorXd moved = offset_h;
    if (p > 0) moved += design_h * beta;
    jac.col(p + static_cast<Eigen::Index>(j)) = (moved - prediction) / dh;
    if (at_bound && (theta[j] - model.theta_lower[j] < 1e-4 * range ||
                     model.theta_upper[j] - theta[j] < 1e-4 * range)) {
      *at_bound = true;
    }
  }
  return jac;
}

Eigen::MatrixXd inverse_normal(const Eigen::MatrixXd& jacobian) {
  Eigen::VectorXd scale;
  const Eigen::MatrixXd inverse = scaled_inverse_normal(jacobian, scale);
  return scale.asDiagonal() * inverse * scale.asDiagonal();
}

double standard_error(const Eigen::MatrixXd& covariance, Eigen::Index i) {
  return std::sqrt(std::max(0.0, covariance(i, i)));
}

Eigen::VectorXd predict_with_theta(const Eigen::VectorXd& y, const SeparableModel& model,
                                   const std::vector<double>& theta,
                                   const std::vector<bool>& train) {
  Eigen::MatrixXd design;
  Eigen::VectorXd offset;
  model.evaluate(theta, design, offset);
  if (design.cols() == 0) return offset;
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < y.size(); ++i) {
    if (train[static_cast<std::size_t>(i)]) rows.push_back(i);
  }
  Eigen::MatrixXd train_design(static_cast<Eigen::Index>(rows.size()), design.cols());
  Eigen::VectorXd train_y(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t r = 0; r < rows.size(); ++r) {
    train_design.row(static_cast<Eigen::Index>(r)) = design.row(rows[r]);
    train_y(static_cast<Eigen::Index>(r)) = y(rows[r]) - offset(rows[r]);
  }
  const Eigen::VectorXd beta = solve_linear(train_design, train_y);
  return offset + design * beta;
}

}  // namespace gyrotc::identify
