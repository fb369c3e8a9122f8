#include "vinci/sim/model/params.h"

#include <sstream>
#include <stdexcept>

namespace vinci::sim {

void ParamTable::Add(ParamInfo info) {
  if (Find(info.name) >= 0) throw std::logic_error("duplicate parameter name '" + info.name + "'");
  info_.push_back(std::move(info));
}

int ParamTable::Find(const std::string& name) const {
  for (int i = 0; i < size(); ++i)
    if (info_[i].name == name) return i;
  // A friction pair's μ under either order of its two materials (the pair is unordered).
  if (name.rfind("mu.", 0) == 0) {
    const std::size_t dot = name.find('.', 3);
    if (dot != std::string::npos && name.find('.', dot + 1) == std::string::npos) {
      const std::string swapped = "mu." + name.substr(dot + 1) + "." + name.substr(3, dot - 3);
      for (int i = 0; i < size(); ++i)
        if (info_[i].kind == ParamKind::kFriction && info_[i].name == swapped) return i;
    }
  }
  return -1;
}

int ParamTable::Index(const std::string& name) const {
  const int i = Find(name);
  if (i >= 0) return i;
  std::ostringstream msg;
  msg << "unknown parameter '" << name << "'; the scene has:";
  for (const ParamInfo& p : info_) msg << ' ' << p.name;
  throw std::invalid_argument(msg.str());
}

Params ParamTable::Defaults() const {
  Params p;
  p.values.resize(size());
  for (int i = 0; i < size(); ++i) p.values[i] = info_[i].default_value;
  return p;
}

std::vector<std::string> ParamTable::DifferentiableNames() const {
  std::vector<std::string> names;
  for (const ParamInfo& p : info_)
    if (p.differentiable) names.push_back(p.name);
  return names;
}

ParamSelection::ParamSelection(const ParamTable& table, const std::vector<std::string>& names) {
  lower_.resize(static_cast<int>(names.size()));
  upper_.resize(static_cast<int>(names.size()));
  for (const std::string& n : names) {
    const int i = table.Index(n);
    lower_[size()] = table.info(i).lower;
    upper_[size()] = table.info(i).upper;
    indices_.push_back(i);
  }
}

VectorXd ParamSelection::Get(const Params& p) const {
  VectorXd x(size());
  for (int k = 0; k < size(); ++k) x[k] = p.values[indices_[k]];
  return x;
}

Params ParamSelection::Set(const Params& base, const VectorXd& x) const {
  if (x.size() != size())
    throw std::invalid_argument("ParamSelection::Set: expected " + std::to_string(size()) +
                                " values, got " + std::to_string(x.size()));
  Params p = base;
  for (int k = 0; k < size(); ++k) p.values[indices_[k]] = x[k];
  return p;
}

}  // namespace vinci::sim
