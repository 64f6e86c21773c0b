// Parameters are declared once (name, default, range, unit, help); scene files, the CLI, the GUI
// and the docs all read the same declaration. Values are held per structure (mesh).
#pragma once

#include "sinew/core/types.h"

#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace sinew {

struct ParamDecl {
  std::string name;
  double defaultValue = 0.0;
  double min = 0.0;
  double max = 1.0;
  std::string unit;  // "" for dimensionless
  std::string help;
  bool perStructure = true;  // false: one value shared by all structures
};

// Every force's first parameter: its activation alpha in [0, 1] per structure.
ParamDecl weightParam();

class ParamTable {
public:
  ParamTable() = default;
  ParamTable(std::vector<ParamDecl> decls, Index rows);

  std::span<const ParamDecl> decls() const { return decls_; }
  Index rows() const { return rows_; }
  // Index of a declared parameter; throws InputError listing the known names.
  int indexOf(std::string_view name) const;

  double get(Index row, int param) const { return values_[row * decls_.size() + param]; }
  float getf(Index row, int param) const { return static_cast<float>(get(row, param)); }
  // Range-checked; a shared parameter is set on every row. Throws InputError naming the value.
  void set(Index row, int param, double value);
  void set(Index row, std::string_view name, double value) { set(row, indexOf(name), value); }
  void setAll(std::string_view name, double value);
  bool anyPositive(int param) const;

private:
  std::vector<ParamDecl> decls_;
  Index rows_ = 0;
  std::vector<double> values_;
};

}  // namespace sinew
