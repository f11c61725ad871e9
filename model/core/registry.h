// Plug-ins by name (policies, backends, PMC sources), filled explicitly by a register_builtin()
// (no static self-registration, which a static library would silently drop). `Info` has at least
// `std::string name`.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/error.h"

namespace rosguard {

template <class Info>
class Registry {
 public:
  // `kind` names the entries in errors ("policy registered twice: interval").
  explicit Registry(std::string kind) : kind_(std::move(kind)) {}

  void add(Info info) {
    if (find(info.name) != nullptr) throw ContractError(kind_ + " registered twice: " + info.name);
    entries_.push_back(std::move(info));
  }
  const Info* find(std::string_view name) const {
    for (const auto& e : entries_)
      if (e.name == name) return &e;
    return nullptr;
  }
  const std::vector<Info>& all() const { return entries_; }

 private:
  std::string kind_;
  std::vector<Info> entries_;
};

}  // namespace rosguard
