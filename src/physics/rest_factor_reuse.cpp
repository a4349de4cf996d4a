#include "topo_gaussian/physics/rest_factor_reuse.h"

#include <sstream>
#include <utility>

#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian {

double RestFactorReuse::newFactorSeconds() const {
  return factor_seconds_ >= 0.0 ? factor_seconds_ : factor_->factorSeconds() + factor_->extraSeconds();
}

double RestFactorReuse::secondsPerApplicationInUse(long applications) const {
  return applications > 0 ? (factor_->applySeconds() - seconds_at_use_) / static_cast<double>(applications) : 0.0;
}

bool RestFactorReuse::refactorise(double first_use, double last_use, double seconds_per_application,
                                  double factor_seconds) {
  return (last_use - first_use) * seconds_per_application > factor_seconds;
}

std::shared_ptr<RestFactorReuse> RestFactorReuse::gpuShared() {
  static const std::shared_ptr<RestFactorReuse> shared = std::make_shared<RestFactorReuse>();
  return shared;
}

std::shared_ptr<const RestStiffnessPreconditioner> RestFactorReuse::find(std::uint64_t user, const CorotatedSph& sph,
                                                                         const std::vector<std::uint8_t>& fixed,
                                                                         double inertia) {
  std::lock_guard<std::mutex> lock(m_);
  if (!factor_) return nullptr;  // none kept: why the last one went stays in refusal_
  refusal_.clear();
  if (factor_->failed()) {
    refusal_ = "its application failed";
    factor_.reset();
    return nullptr;
  }
  if (inertia != inertia_ || sph.smoothingLength() != h_ || fixed != fixed_ || sph.restPositions() != X_) {
    refusal_ = "another body, clamp or inertia";
    factor_.reset();
    return nullptr;
  }
  if (user == user_) return factor_;  // the same use
  if (factor_.use_count() > 1) {      // still held by the simulator of the last use: not shared
    refusal_ = "held by another simulator";
    return nullptr;
  }
  const long now = factor_->applications();
  const long last = now - applications_at_use_;
  if (first_use_ < 0) {
    first_use_ = last;
    first_solves_ = solves_in_use_;
  }
  const double per_application = secondsPerApplicationInUse(last);
  const double new_factor = newFactorSeconds();
  if (uses_ > 1 && refactorise(first_use_, last, per_application, new_factor)) {
    std::ostringstream s;
    s << "its last use took " << last << " applications against " << first_use_ << " in its first, "
      << numberText(static_cast<double>(last - first_use_) * per_application, 3) << " s more than a new factor's "
      << numberText(new_factor, 3) << " s";
    refusal_ = s.str();
    factor_.reset();  // its memory back before the next factor is made
    return nullptr;
  }
  user_ = user;
  applications_at_use_ = now;
  seconds_at_use_ = factor_->applySeconds();
  solves_in_use_ = 1;
  ++uses_;
  ++counts_.reuses;
  return factor_;
}

bool RestFactorReuse::renewDuringUse(std::uint64_t user) {
  std::lock_guard<std::mutex> lock(m_);
  if (!factor_ || user != user_) return false;
  ++solves_in_use_;
  if (!renew_during_use_ || uses_ < 2 || first_solves_ <= 0) return false;  // its own design's use
  const long applications = factor_->applications() - applications_at_use_;
  const double expected = static_cast<double>(solves_in_use_ - 1) * static_cast<double>(first_use_) /
                          static_cast<double>(first_solves_);  // the solves before this one
  const double per_application = secondsPerApplicationInUse(applications);
  const double new_factor = newFactorSeconds();
  if (!refactorise(expected, static_cast<double>(applications), per_application, new_factor)) return false;
  std::ostringstream s;
  s << "during a use, " << applications << " applications in " << solves_in_use_ - 1 << " solves against "
    << numberText(static_cast<double>(first_use_) / static_cast<double>(first_solves_), 3)
    << " a solve in its first use, " << numberText((static_cast<double>(applications) - expected) * per_application, 3)
    << " s more than a new factor's " << numberText(new_factor, 3) << " s";
  refusal_ = s.str();
  factor_.reset();  // its memory back (once the simulator lets go) before the next factor is made
  ++counts_.renewed_during_use;
  return true;
}

void RestFactorReuse::store(std::uint64_t user, std::shared_ptr<const RestStiffnessPreconditioner> factor,
                            const CorotatedSph& sph, const std::vector<std::uint8_t>& fixed, double inertia) {
  std::vector<Eigen::Vector3d> X = sph.restPositions();  // copied before anything is replaced
  std::vector<std::uint8_t> mask = fixed;
  std::lock_guard<std::mutex> lock(m_);
  X_.swap(X);
  fixed_.swap(mask);
  factor_ = std::move(factor);
  h_ = sph.smoothingLength();
  inertia_ = inertia;
  user_ = user;
  applications_at_use_ = factor_ ? factor_->applications() : 0;
  seconds_at_use_ = factor_ ? factor_->applySeconds() : 0.0;
  first_use_ = -1;
  uses_ = 1;
  solves_in_use_ = 1;
  first_solves_ = 0;
  ++counts_.factors;
}

void RestFactorReuse::clear() {
  std::lock_guard<std::mutex> lock(m_);
  factor_.reset();
  user_ = 0;
}

RestFactorReuse::Counts RestFactorReuse::counts() const {
  std::lock_guard<std::mutex> lock(m_);
  return counts_;
}

std::string RestFactorReuse::lastRefusal() const {
  std::lock_guard<std::mutex> lock(m_);
  return refusal_;
}

}  // namespace topo_gaussian
