#include "scenario/sweep.h"

#include <cctype>
#include <cstdio>
#include <map>

#include "core/hash.h"

namespace rosguard {

std::vector<std::string> split_sweep_key(const std::string& key) {
  std::vector<std::string> paths;
  std::size_t start = 0;
  while (true) {
    const std::size_t plus = key.find('+', start);
    paths.push_back(key.substr(start, plus - start));
    if (plus == std::string::npos) break;
    start = plus + 1;
  }
  return paths;
}

std::vector<PathSegment> parse_sweep_path(const std::string& path) {
  std::vector<PathSegment> out;
  std::size_t i = 0;
  const auto fail = [&](const std::string& why) {
    throw InputError("", "", "malformed sweep path '" + path + "': " + why);
  };
  while (true) {
    PathSegment seg;
    while (i < path.size() && path[i] != '.' && path[i] != '[')
      seg.key += path[i++];
    if (seg.key.empty()) fail("empty key at character " + std::to_string(i + 1));
    while (i < path.size() && path[i] == '[') {
      const std::size_t close = path.find(']', i);
      if (close == std::string::npos || close == i + 1) fail("bad array index");
      std::size_t index = 0;
      for (std::size_t k = i + 1; k < close; ++k) {
        if (!std::isdigit(static_cast<unsigned char>(path[k]))) fail("bad array index");
        index = index * 10 + static_cast<std::size_t>(path[k] - '0');
      }
      seg.indexes.push_back(index);
      i = close + 1;
    }
    out.push_back(std::move(seg));
    if (i == path.size()) break;
    if (path[i] != '.') fail("expected '.' at character " + std::to_string(i + 1));
    ++i;
  }
  return out;
}

std::string to_json_pointer(const std::vector<PathSegment>& path) {
  std::string out;
  for (const auto& seg : path) {
    std::string key = "/";  // JSON pointer escaping: ~ -> ~0, / -> ~1
    for (char c : seg.key)
      key += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
    out += key;
    for (std::size_t index : seg.indexes) {
      out += '/';
      out += std::to_string(index);
    }
  }
  return out;
}

void set_at_path(nlohmann::json& doc, const std::vector<PathSegment>& path,
                 const nlohmann::json& value) {
  nlohmann::json* node = &doc;
  std::string walked;
  for (std::size_t s = 0; s < path.size(); ++s) {
    const PathSegment& seg = path[s];
    if (!node->is_object())
      throw InputError("", "",
                       "'" + walked + "' is not an object, it has no key '" + seg.key + "'");
    walked += (walked.empty() ? "" : ".") + seg.key;
    const bool last_key = s + 1 == path.size();
    if (!node->contains(seg.key)) {
      if (!seg.indexes.empty())
        throw InputError("", "", "'" + walked + "' does not exist, so it cannot be indexed");
      if (!last_key) (*node)[seg.key] = nlohmann::json::object();
    }
    node = &(*node)[seg.key];
    for (std::size_t index : seg.indexes) {
      if (!node->is_array()) throw InputError("", "", "'" + walked + "' is not an array");
      if (index >= node->size())
        throw InputError("", "",
                         "'" + walked + "' has " + std::to_string(node->size()) +
                             " element(s), no index " + std::to_string(index));
      walked += '[';
      walked += std::to_string(index);
      walked += ']';
      node = &(*node)[index];
    }
  }
  *node = value;
}

std::string point_id(const std::vector<SweepParam>& params) {
  // FNV-1a over "path=value;" in sweep key order (values in nlohmann's canonical dump).
  std::uint64_t h = fnv1a("");
  for (const auto& p : params)
    h = fnv1a(p.path + "=" + p.value.dump() + ";", h);
  char buf[16];
  std::snprintf(buf, sizeof buf, "p%010llx", static_cast<unsigned long long>(h & 0xffffffffffULL));
  return buf;
}

SweepPlan::SweepPlan(const nlohmann::json& doc, const std::vector<std::string>& key_order)
    : base_(doc) {
  static const nlohmann::json empty = nlohmann::json::object();
  const nlohmann::json& sweep = doc.contains("sweep") ? doc.at("sweep") : empty;
  base_.erase("sweep");
  if (key_order.size() != sweep.size())
    throw ContractError("sweep key order does not match the sweep object");
  // Each swept path's JSON pointer and the key that sweeps it: a path set by two keys (or by one
  // key and a key setting a part of it) would take one key's value and drop the other's.
  std::vector<std::pair<std::string, std::string>> swept;
  for (const auto& key : key_order) {
    const std::string where = "/sweep" + to_json_pointer({{key, {}}});
    Key k{key, split_sweep_key(key), {}, &sweep.at(key)};
    for (const auto& name : k.names) {
      try {
        k.paths.push_back(parse_sweep_path(name));
      } catch (const InputError& e) {
        throw InputError("", where, e.message());
      }
      const std::string ptr = to_json_pointer(k.paths.back());
      for (const auto& [other, by] : swept) {
        const auto within = [](const std::string& a, const std::string& b) {
          return a == b ||
                 (b.size() > a.size() && b.compare(0, a.size(), a) == 0 && b[a.size()] == '/');
        };
        if (within(ptr, other) || within(other, ptr))
          throw InputError("", where,
                           "'" + name + "' is swept by two keys ('" + by + "' and '" + key +
                               "'): each point would take one key's value and drop the "
                               "other's; sweep each path in one key");
      }
      swept.emplace_back(ptr, key);
    }
    if (!k.values->is_array() || k.values->empty())
      throw InputError("", where, "sweep '" + key + "' must be a non-empty list");
    if (k.names.size() > 1)
      for (std::size_t i = 0; i < k.values->size(); ++i)
        if (!(*k.values)[i].is_array() || (*k.values)[i].size() != k.names.size())
          throw InputError("", where + "/" + std::to_string(i),
                           "sweep '" + key + "' joins " + std::to_string(k.names.size()) +
                               " paths, so each value must be a list of " +
                               std::to_string(k.names.size()) + " values (value " +
                               std::to_string(i) + " is not)");
    // Equal values would make equal points: each run twice, and two rows with one meaning.
    std::map<nlohmann::json, std::size_t> seen;  // json's order: 5 and 5.0 are one value
    for (std::size_t i = 0; i < k.values->size(); ++i)
      if (const auto [it, fresh] = seen.emplace((*k.values)[i], i); !fresh)
        throw InputError("", where + "/" + std::to_string(i),
                         "sweep '" + key + "' repeats value " + std::to_string(it->second) + " (" +
                             (*k.values)[i].dump() + "); each value may appear once");
    if (__builtin_mul_overflow(count_, static_cast<std::uint64_t>(k.values->size()), &count_))
      throw InputError("", "/sweep",
                       "the sweep has more points than a 64-bit count can hold (" +
                           std::to_string(UINT64_MAX) + ")");
    keys_.push_back(std::move(k));
  }
}

std::vector<std::uint64_t> SweepPlan::sizes() const {
  std::vector<std::uint64_t> out;
  for (const auto& k : keys_)
    out.push_back(k.values->size());
  return out;
}

SweepPoint SweepPlan::point(std::uint64_t index) const {
  // Mixed radix, the last key varying fastest.
  std::vector<std::size_t> digit(keys_.size(), 0);
  for (std::uint64_t rest = index, k = keys_.size(); k-- > 0;) {
    digit[k] = static_cast<std::size_t>(rest % keys_[k].values->size());
    rest /= keys_[k].values->size();
  }
  SweepPoint p;
  p.index = static_cast<std::size_t>(index);
  p.document = base_;
  for (std::size_t k = 0; k < keys_.size(); ++k) {
    const Key& key = keys_[k];
    const auto& value = (*key.values)[digit[k]];
    for (std::size_t c = 0; c < key.names.size(); ++c) {
      const auto& v = key.names.size() > 1 ? value[c] : value;
      try {
        set_at_path(p.document, key.paths[c], v);
      } catch (const InputError& e) {
        throw SweepPathError(key.key, e.message());
      }
      p.params.push_back({key.names[c], v, digit[k], key.key, c});
    }
  }
  p.id = point_id(p.params);
  return p;
}

std::vector<SweepPoint> expand_sweep(const nlohmann::json& doc,
                                     const std::vector<std::string>& key_order) {
  const SweepPlan plan(doc, key_order);
  std::vector<SweepPoint> points;
  for (std::uint64_t i = 0; i < plan.count(); ++i)
    points.push_back(plan.point(i));
  return points;
}

}  // namespace rosguard
