#include "sinew/core/parameters.h"

#include <cmath>
#include <sstream>

namespace sinew {

ParamDecl weightParam() {
  return {"weight", 1.0, 0.0, 1.0, "",
          "activation alpha of this force for the structure (0 switches it off)", true};
}

ParamTable::ParamTable(std::vector<ParamDecl> decls, Index rows)
    : decls_(std::move(decls)), rows_(rows), values_(decls_.size() * rows) {
  for (Index r = 0; r < rows_; ++r)
    for (size_t p = 0; p < decls_.size(); ++p) values_[r * decls_.size() + p] = decls_[p].defaultValue;
}

int ParamTable::indexOf(std::string_view name) const {
  for (size_t p = 0; p < decls_.size(); ++p)
    if (decls_[p].name == name) return static_cast<int>(p);
  std::ostringstream m;
  m << "unknown parameter '" << name << "' (known:";
  for (const auto& d : decls_) m << ' ' << d.name;
  m << ')';
  throw InputError(m.str());
}

void ParamTable::set(Index row, int param, double value) {
  const ParamDecl& d = decls_.at(param);
  if (!std::isfinite(value) || value < d.min || value > d.max) {
    std::ostringstream m;
    m << "parameter '" << d.name << "' = " << value << " is outside its range [" << d.min << ", "
      << d.max << "]" << (d.unit.empty() ? "" : " " + d.unit);
    throw InputError(m.str());
  }
  if (row < 0 || row >= rows_) throw InputError("parameter '" + d.name + "': no such structure");
  if (!d.perStructure) {
    for (Index r = 0; r < rows_; ++r) values_[r * decls_.size() + param] = value;
  } else {
    values_[row * decls_.size() + param] = value;
  }
}

void ParamTable::setAll(std::string_view name, double value) {
  const int p = indexOf(name);
  for (Index r = 0; r < rows_; ++r) set(r, p, value);
}

bool ParamTable::anyPositive(int param) const {
  for (Index r = 0; r < rows_; ++r)
    if (get(r, param) > 0.0) return true;
  return false;
}

}  // namespace sinew
