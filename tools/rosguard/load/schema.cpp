#include "load/schema.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <regex>
#include <string_view>
#include <valijson/adapters/nlohmann_json_adapter.hpp>
#include <valijson/schema.hpp>
#include <valijson/schema_parser.hpp>
#include <valijson/validator.hpp>

#include "core/error.h"

namespace rosguard {
namespace {

using json = nlohmann::json;

const char* file_of(SchemaKind kind) {
  switch (kind) {
    case SchemaKind::Scenario:
      return "scenario.schema.json";
    case SchemaKind::Platform:
      return "platform.schema.json";
    case SchemaKind::Workload:
      return "workload.schema.json";
    case SchemaKind::Guard:
      return "guard.schema.json";
  }
  return "";
}

std::string type_name(const json& v) {
  switch (v.type()) {
    case json::value_t::null:
      return "null";
    case json::value_t::boolean:
      return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
      return "an integer";
    case json::value_t::number_float:
      return "a number";
    case json::value_t::string:
      return "a string";
    case json::value_t::array:
      return "a list";
    case json::value_t::object:
      return "an object";
    default:
      return "something else";
  }
}

std::string schema_type_name(const std::string& t) {
  if (t == "integer") return "an integer";
  if (t == "number") return "a number";
  if (t == "string") return "a string";
  if (t == "boolean") return "true or false";
  if (t == "array") return "a list";
  if (t == "object") return "an object";
  return t;
}

std::string shown(const json& v) {
  std::string s = v.dump();
  return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

// valijson's nlohmann adapter reads every integer as an int64_t: an unsigned one above INT64_MAX
// wraps negative, so a u64 seed of 2^63 or more failed "minimum": 0, and such a value passed any
// "maximum". An integer field takes one only where its schema says so with a "maximum" of 2^63
// or more (the seed's: 18446744073709551615); elsewhere the code reads int64_t or less. So:
// - valijson validates a copy of the document with these values as INT64_MAX: the same type,
//   and the same verdict against every bound below 2^63 (errors are rendered from the document
//   as given);
// - it compiles the schemas without the bounds it would misread (an unsigned above INT64_MAX is
//   -1 to it as well), and SchemaSet::Impl::check_big_unsigned judges these values against them
//   exactly, refusing them where the schema has no such bound.
// Whether schema node `s` wants a number ("type" integer or number, alone or among others).
bool is_number_type(const json& s) {
  const auto number = [](const json& t) { return t == "integer" || t == "number"; };
  if (!s.contains("type")) return false;
  const json& t = s["type"];
  return t.is_array() ? std::any_of(t.begin(), t.end(), number) : number(t);
}

constexpr std::uint64_t kInt64Max = std::numeric_limits<std::int64_t>::max();

bool big_unsigned(const json& v) {
  return v.is_number_unsigned() && v.get<std::uint64_t>() > kInt64Max;
}

bool has_big_unsigned(const json& v) {
  if (big_unsigned(v)) return true;
  if (v.is_structured())
    return std::any_of(v.begin(), v.end(), [](const json& e) { return has_big_unsigned(e); });
  return false;
}

void clamp_big_unsigned(json& v) {
  if (big_unsigned(v)) {
    v = std::numeric_limits<std::int64_t>::max();
  } else if (v.is_structured()) {
    for (auto& e : v)
      clamp_big_unsigned(e);
  }
}

// A schema document as valijson gets it: without the bounds above INT64_MAX.
json without_big_bounds(json schema) {
  const std::function<void(json&)> strip = [&](json& n) {
    if (n.is_object())
      for (const char* bound : {"maximum", "exclusiveMaximum"})
        if (n.contains(bound) && big_unsigned(n[bound])) n.erase(bound);
    if (n.is_structured())
      for (auto& e : n)
        strip(e);
  };
  strip(schema);
  return schema;
}

constexpr std::string_view kBeyond64Bits = " (beyond the 64-bit integers)";

// A number written as an integer too long for 64 bits (nlohmann reads it as a double).
bool beyond_64_bit_integers(const json& v) {
  if (!v.is_number_float()) return false;
  const double d = v.get<double>();
  return std::isfinite(d) && std::nearbyint(d) == d && (d >= 0x1p64 || d <= -0x1p63);
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string escape_token(const std::string& t) {
  std::string out;
  for (char c : t)
    out += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
  return out;
}

// Text between the last pair of single quotes of a valijson description.
std::string quoted_name(const std::string& description) {
  const auto end = description.rfind('\'');
  if (end == std::string::npos || end == 0) return "";
  const auto begin = description.rfind('\'', end - 1);
  return begin == std::string::npos ? "" : description.substr(begin + 1, end - begin - 1);
}

bool is_wrapper(const std::string& d) {
  static const char* const prefixes[] = {
      "Failed to validate against schema associated with property name",
      "Failed to validate item #",
      "Failed to validate against child schema",
      "Failed to validate against any child schemas",
      "Failed to validate against",
      "Failed to validate additional properties",
      "Failed to validate properties",
  };
  return std::any_of(std::begin(prefixes), std::end(prefixes),
                     [&](const char* p) { return d.rfind(p, 0) == 0; });
}

}  // namespace

struct SchemaSet::Impl {
  std::map<std::string, json> docs;  // schema file name -> document
  std::map<SchemaKind, std::unique_ptr<valijson::Schema>> compiled;
  // Validators kept for reuse: each keeps the std::regex of every "pattern" it compiled (a
  // fresh validator per document compiled them all again: most of the time a 10,000-point sweep
  // took to load). A validator is not thread-safe, so each call borrows one (Loader::load_points
  // checks points on several threads).
  mutable std::mutex validators_mutex;
  mutable std::vector<std::unique_ptr<valijson::Validator>> validators;

  std::unique_ptr<valijson::Validator> borrow() const {
    const std::lock_guard<std::mutex> lock(validators_mutex);
    if (validators.empty()) return std::make_unique<valijson::Validator>();
    auto v = std::move(validators.back());
    validators.pop_back();
    return v;
  }
  void give_back(std::unique_ptr<valijson::Validator> v) const {
    const std::lock_guard<std::mutex> lock(validators_mutex);
    validators.push_back(std::move(v));
  }

  // A schema node and the file it lives in (for resolving its relative $refs).
  struct Node {
    const json* schema = nullptr;
    std::string file;
  };

  Node resolve(Node n) const {
    for (int guard = 0;
         guard < 16 && n.schema && n.schema->is_object() && n.schema->contains("$ref"); ++guard) {
      const std::string ref = n.schema->at("$ref").get<std::string>();
      const auto hash = ref.find('#');
      const std::string file = hash == 0 ? n.file : ref.substr(0, hash);
      const std::string pointer = hash == std::string::npos ? "" : ref.substr(hash + 1);
      auto it = docs.find(file);
      if (it == docs.end()) return {};
      n = {&it->second.at(json::json_pointer(pointer)), file};
    }
    return n;
  }

  // Minimal evaluation of the "if" forms our schemas use: required keys, a type, const values.
  static bool if_matches(const json& cond, const json& instance) {
    if (cond.contains("type") && cond["type"] == "object" && !instance.is_object()) return false;
    if (cond.contains("required")) {
      if (!instance.is_object()) return false;
      for (const auto& k : cond["required"])
        if (!instance.contains(k.get<std::string>())) return false;
    }
    if (cond.contains("properties") && instance.is_object())
      for (const auto& [k, sub] : cond["properties"].items())
        if (sub.contains("const") && (!instance.contains(k) || instance[k] != sub["const"]))
          return false;
    return true;
  }

  // The branches of `n` that apply to `instance`: itself, then its matching then/else/allOf.
  // With `all`, every conditional branch is included whatever the instance (for suggestions).
  void branches(Node n, const json& instance, std::vector<Node>& out, bool all = false) const {
    n = resolve(n);
    if (!n.schema || !n.schema->is_object()) return;
    out.push_back(n);
    const json& s = *n.schema;
    if (s.contains("if")) {
      const bool match = if_matches(s["if"], instance);
      if ((all || match) && s.contains("then")) branches({&s["then"], n.file}, instance, out, all);
      if ((all || !match) && s.contains("else")) branches({&s["else"], n.file}, instance, out, all);
    }
    if (s.contains("allOf"))
      for (const auto& sub : s["allOf"])
        branches({&sub, n.file}, instance, out, all);
  }

  // Subschema for key `key` of object `instance` under schema `n`.
  std::optional<Node> child(Node n, const json& instance, const std::string& key) const {
    std::vector<Node> bs;
    branches(n, instance, bs);
    for (const Node& b : bs)
      if (b.schema->contains("properties") && (*b.schema)["properties"].contains(key))
        return Node{&(*b.schema)["properties"][key], b.file};
    for (const Node& b : bs)
      if (b.schema->contains("additionalProperties") &&
          (*b.schema)["additionalProperties"].is_object())
        return Node{&(*b.schema)["additionalProperties"], b.file};
    return std::nullopt;
  }

  // Walks schema and instance along `tokens`; returns the schema node and instance value there.
  std::pair<std::optional<Node>, const json*> locate(SchemaKind kind, const json& doc,
                                                     const std::vector<std::string>& tokens) const {
    std::optional<Node> n = Node{&docs.at(file_of(kind)), file_of(kind)};
    const json* inst = &doc;
    for (const auto& t : tokens) {
      if (!n || !inst) return {std::nullopt, nullptr};
      if (inst->is_array()) {
        std::vector<Node> bs;
        branches(*n, *inst, bs);
        std::optional<Node> items;
        for (const Node& b : bs)
          if (b.schema->contains("items")) items = Node{&(*b.schema)["items"], b.file};
        n = items;
        const std::size_t i = std::stoul(t);
        inst = i < inst->size() ? &(*inst)[i] : nullptr;
      } else if (inst->is_object()) {
        n = child(*n, *inst, t);
        inst = inst->contains(t) ? &(*inst)[t] : nullptr;
      } else {
        return {std::nullopt, nullptr};
      }
    }
    return {n, inst};
  }

  std::vector<std::string> allowed_keys(Node n, const json& instance) const {
    std::vector<Node> bs;
    branches(n, instance, bs, true);
    std::vector<std::string> keys;
    for (const Node& b : bs)
      if (b.schema->contains("properties"))
        for (const auto& [k, _] : (*b.schema)["properties"].items())
          if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
    return keys;
  }

  std::string range_text(const json& s) const {
    const auto num = [](const json& v) { return v.dump(); };
    const bool has_lo = s.contains("minimum") || s.contains("exclusiveMinimum");
    const bool has_hi = s.contains("maximum") || s.contains("exclusiveMaximum");
    const bool lo_open = s.contains("exclusiveMinimum");
    const bool hi_open = s.contains("exclusiveMaximum");
    const std::string lo = has_lo ? num(lo_open ? s["exclusiveMinimum"] : s["minimum"]) : "";
    const std::string hi = has_hi ? num(hi_open ? s["exclusiveMaximum"] : s["maximum"]) : "";
    if (has_lo && has_hi)
      return "in " + std::string(lo_open ? "(" : "[") + lo + ", " + hi + (hi_open ? ")" : "]");
    if (has_lo) return std::string(lo_open ? "> " : ">= ") + lo;
    if (has_hi) return std::string(hi_open ? "< " : "<= ") + hi;
    return "in range";
  }

  // The range of an integer: its schema's bounds, the upper one INT64_MAX where it has none.
  std::string integer_range_text(const json& s) const {
    if (s.contains("maximum") || s.contains("exclusiveMaximum")) return range_text(s);
    const bool open = s.contains("exclusiveMinimum");
    const std::string lo = s.contains("minimum") ? s["minimum"].dump()
                           : open                ? s["exclusiveMinimum"].dump()
                                  : std::to_string(std::numeric_limits<std::int64_t>::min());
    return std::string(open ? "in (" : "in [") + lo + ", " + std::to_string(kInt64Max) + "]";
  }

  // The integers above INT64_MAX in `doc` (validated as INT64_MAX) against the schema's own
  // bounds: allowed up to a "maximum" of 2^63 or more, refused where a number's schema has no
  // upper bound (the fields the code reads as int64_t or less); those with a lower "maximum" are
  // in `out` already (valijson's error at INT64_MAX). A value the schema does not constrain (a
  // sweep's) is judged where it lands.
  void check_big_unsigned(SchemaKind kind, const json& doc, std::vector<std::string>& tokens,
                          const json& v,
                          std::vector<std::pair<std::string, std::string>>& out) const {
    if (v.is_object()) {
      for (const auto& [key, e] : v.items()) {
        tokens.push_back(key);
        check_big_unsigned(kind, doc, tokens, e, out);
        tokens.pop_back();
      }
    } else if (v.is_array()) {
      for (std::size_t i = 0; i < v.size(); ++i) {
        tokens.push_back(std::to_string(i));
        check_big_unsigned(kind, doc, tokens, v[i], out);
        tokens.pop_back();
      }
    }
    if (!big_unsigned(v)) return;
    std::string pointer;
    for (const auto& t : tokens)
      pointer += "/" + escape_token(t);
    if (std::any_of(out.begin(), out.end(), [&](const auto& e) { return e.first == pointer; }))
      return;  // already wrong there
    const auto [node, inst] = locate(kind, doc, tokens);
    const json* s = node ? resolve(*node).schema : nullptr;
    const auto value = v.get<std::uint64_t>();
    if (s && s->contains("maximum") && big_unsigned((*s)["maximum"])) {
      if (value <= (*s)["maximum"].get<std::uint64_t>()) return;
      out.push_back({pointer, "must be " + range_text(*s) + ", not " + shown(v)});
    } else if (s && s->contains("exclusiveMaximum") && big_unsigned((*s)["exclusiveMaximum"])) {
      if (value < (*s)["exclusiveMaximum"].get<std::uint64_t>()) return;
      out.push_back({pointer, "must be " + range_text(*s) + ", not " + shown(v)});
    } else if (s && is_number_type(*s) && !s->contains("maximum") &&
               !s->contains("exclusiveMaximum")) {
      out.push_back(
          {pointer, "must be an integer " + integer_range_text(*s) + ", not " + shown(v)});
    }
  }

  // valijson reports some failures (propertyNames) only as "failed to validate against the
  // schema of property X": find what is wrong at X from the schema itself.
  std::pair<std::string, std::string> explain_wrapper(
      SchemaKind kind, const json& doc, const valijson::ValidationResults::Error& e) const {
    std::vector<std::string> tokens;
    for (const auto& c : e.context)
      if (c.size() >= 2 && c.front() == '[' && c.back() == ']')
        tokens.push_back(c.substr(1, c.size() - 2));
    if (const std::string name = quoted_name(e.description); !name.empty()) tokens.push_back(name);
    std::string pointer;
    for (const auto& t : tokens)
      pointer += "/" + escape_token(t);
    const auto [node, inst] = locate(kind, doc, tokens);
    const json* s = node ? resolve(*node).schema : nullptr;
    if (s && inst && inst->is_object() && s->contains("propertyNames")) {
      const json& names = (*s)["propertyNames"];
      const std::size_t max_length = names.value("maxLength", std::size_t{4096});
      for (const auto& [key, _] : inst->items())
        if (key.size() > max_length)
          return {pointer, "key of " + std::to_string(key.size()) +
                               " characters is not valid here: expected " +
                               names.value("description", "a key") + ", at most " +
                               std::to_string(max_length) + " characters"};
      // The parser bounds keys (kMaxJsonStringChars), so std::regex cannot recurse too deep.
      const std::regex re(names.value("pattern", ".*"));
      for (const auto& [key, _] : inst->items())
        if (!std::regex_search(key, re))
          return {pointer,
                  "key '" + key + "' is not valid here: expected " +
                      names.value("description", "a key matching " + names.value("pattern", "?"))};
    }
    return {pointer, "does not match " + std::string(file_of(kind)) + " here"};
  }

  // Turns one valijson error into (JSON pointer, message).
  std::pair<std::string, std::string> render(SchemaKind kind, const json& doc,
                                             const valijson::ValidationResults::Error& e) const {
    std::vector<std::string> tokens;
    for (const auto& c : e.context)
      if (c.size() >= 2 && c.front() == '[' && c.back() == ']')
        tokens.push_back(c.substr(1, c.size() - 2));
    std::string pointer;
    for (const auto& t : tokens)
      pointer += "/" + escape_token(t);
    const auto [node, inst] = locate(kind, doc, tokens);
    const json* s = node ? resolve(*node).schema : nullptr;
    const std::string& d = e.description;

    if (d.find("could not be validated using 'properties' or 'additionalProperties'") !=
        std::string::npos) {
      const std::string key = quoted_name(d);
      std::string msg = "unknown key '" + key + "'";
      if (node && inst) {
        const auto keys = allowed_keys(*node, *inst);
        std::string best;
        std::size_t best_d = key.size() / 3 + 2;
        for (const auto& k : keys)
          if (const std::size_t dist = edit_distance(key, k); dist < best_d) {
            best = k;
            best_d = dist;
          }
        if (!best.empty()) msg += " (did you mean '" + best + "'?)";
        std::string list;
        for (const auto& k : keys)
          if (k != "$schema") list += (list.empty() ? "" : ", ") + k;
        if (!list.empty()) msg += "; allowed here: " + list;
      }
      return {pointer + "/" + escape_token(key), msg};
    }
    // A top-level key the schema's if/then forbids ("not": {}) says why in its description.
    if (d.find("'not' constraint") != std::string::npos && tokens.size() == 1) {
      const json& root = docs.at(file_of(kind));
      const json::json_pointer why("/then/properties/" + escape_token(tokens[0]) + "/description");
      if (root.contains(why)) return {pointer, root.at(why).get<std::string>()};
    }
    if (d.rfind("Missing required property", 0) == 0)
      return {pointer, "missing required key '" + quoted_name(d) + "'"};
    if (d.find("'type' constraint") != std::string::npos && s && inst) {
      std::string want;
      const json& t = (*s)["type"];
      if (t.is_string()) {
        want = schema_type_name(t.get<std::string>());
      } else if (t.is_array()) {
        for (std::size_t i = 0; i < t.size(); ++i)
          want += (i ? " or " : "") + schema_type_name(t[i].get<std::string>());
      }
      if (t == "integer" && beyond_64_bit_integers(*inst))
        return {pointer, "must be an integer " + integer_range_text(*s) + ", not " + shown(*inst) +
                             std::string(kBeyond64Bits)};
      return {pointer, "must be " + want + ", not " + type_name(*inst) + " (" + shown(*inst) + ")"};
    }
    if (d.find("enum values") != std::string::npos && s && s->contains("enum")) {
      std::string list;
      for (const auto& v : (*s)["enum"])
        list += (list.empty() ? "" : ", ") + v.dump();
      return {pointer, "must be one of " + list + (inst ? ", not " + shown(*inst) : std::string())};
    }
    if ((d.rfind("Expected number", 0) == 0 || d.find("less than") != std::string::npos ||
         d.find("greater than") != std::string::npos) &&
        s) {
      return {pointer, "must be " + range_text(*s) + (inst ? ", not " + shown(*inst) : "")};
    }
    if (d.rfind("String should be no more than", 0) == 0 && s && inst && inst->is_string())
      return {pointer, "must be at most " + (*s)["maxLength"].dump() + " characters long, not " +
                           std::to_string(inst->get_ref<const std::string&>().size())};
    if (d.find("no fewer than") != std::string::npos) {
      if (inst && inst->is_string()) return {pointer, "must not be empty"};
      if (inst && inst->is_object()) return {pointer, "must have at least one entry"};
      return {pointer, "must not be an empty list"};
    }
    if (d.find("regex") != std::string::npos && inst) {
      std::string hint = s && s->contains("pattern")
                             ? " (pattern " + (*s)["pattern"].get<std::string>() + ")"
                             : "";
      return {pointer, shown(*inst) + " is not a valid value here" + hint};
    }
    if (d.find("property names") != std::string::npos ||
        d.find("propertyNames") != std::string::npos)
      return {pointer, "has an invalid key: " + d};
    return {pointer, d};
  }
};

SchemaSet::SchemaSet(const std::filesystem::path& dir) : impl_(std::make_unique<Impl>()) {
  for (SchemaKind kind :
       {SchemaKind::Scenario, SchemaKind::Platform, SchemaKind::Workload, SchemaKind::Guard}) {
    const auto path = dir / file_of(kind);
    std::ifstream in(path);
    if (!in) throw RunError("cannot read schema " + path.string());
    try {
      impl_->docs[file_of(kind)] = json::parse(in);
    } catch (const json::parse_error& e) {
      throw RunError("schema " + path.string() + " is not valid JSON: " + e.what());
    }
  }
  using Adapter = valijson::adapters::NlohmannJsonAdapter;
  std::map<std::string, json> compiled;  // see without_big_bounds
  for (const auto& [file, doc] : impl_->docs)
    compiled[file] = without_big_bounds(doc);
  for (SchemaKind kind :
       {SchemaKind::Scenario, SchemaKind::Platform, SchemaKind::Workload, SchemaKind::Guard}) {
    auto schema = std::make_unique<valijson::Schema>();
    valijson::SchemaParser parser;
    Adapter adapter(compiled[file_of(kind)]);
    const auto fetch = [&compiled](const std::string& uri) -> const json* {
      auto it = compiled.find(uri);
      return it == compiled.end() ? nullptr : new json(it->second);
    };
    const auto release = [](const json* doc) { delete doc; };
    parser.populateSchema(adapter, *schema, fetch, release);
    impl_->compiled[kind] = std::move(schema);
  }
}

SchemaSet::~SchemaSet() = default;

std::vector<std::pair<std::string, std::string>> SchemaSet::errors(const json& doc,
                                                                   SchemaKind kind) const {
  valijson::ValidationResults results;
  std::optional<json> clamped;  // see big_unsigned
  if (has_big_unsigned(doc)) clamp_big_unsigned(clamped.emplace(doc));
  valijson::adapters::NlohmannJsonAdapter adapter(clamped ? *clamped : doc);
  std::unique_ptr<valijson::Validator> validator = impl_->borrow();
  const bool valid = validator->validate(*impl_->compiled.at(kind), adapter, &results);
  impl_->give_back(std::move(validator));
  std::vector<std::pair<std::string, std::string>> out;
  if (valid) {
    if (clamped) {
      std::vector<std::string> tokens;
      impl_->check_big_unsigned(kind, doc, tokens, doc, out);
    }
    return out;
  }
  valijson::ValidationResults::Error e;
  valijson::ValidationResults::Error deepest;
  while (results.popError(e)) {
    if (is_wrapper(e.description)) {
      if (e.context.size() >= deepest.context.size()) deepest = e;
      continue;
    }
    out.push_back(impl_->render(kind, doc, e));
  }
  // An integer beyond 64 bits also breaks the bounds it is compared with as a double: its type
  // error says both.
  for (const auto& [pointer, message] : std::vector(out))
    if (message.ends_with(kBeyond64Bits))
      std::erase_if(out, [&](const auto& other) {
        return other.first == pointer && !other.second.ends_with(kBeyond64Bits);
      });
  if (clamped) {
    std::vector<std::string> tokens;
    impl_->check_big_unsigned(kind, doc, tokens, doc, out);
  }
  if (out.empty()) out.push_back(impl_->explain_wrapper(kind, doc, deepest));
  return out;
}

std::optional<std::pair<std::string, std::string>> SchemaSet::first_error(const json& doc,
                                                                          SchemaKind kind) const {
  const auto all = errors(doc, kind);
  if (all.empty()) return std::nullopt;
  return std::make_pair(all.front().first,
                        all.front().second + InputError::more_suffix(all.size() - 1));
}

void SchemaSet::validate(const json& doc, SchemaKind kind, const std::string& file) const {
  if (auto all = errors(doc, kind); !all.empty()) throw InputError(file, std::move(all));
}

void SchemaSet::apply_defaults(json& doc, SchemaKind kind) const {
  using Node = Impl::Node;
  const std::function<void(Node, json&)> walk = [&](Node n, json& inst) {
    n = impl_->resolve(n);
    if (!n.schema || !n.schema->is_object()) return;
    const json& s = *n.schema;
    if (inst.is_object() && s.contains("properties")) {
      for (const auto& [key, sub] : s["properties"].items()) {
        const Node child = impl_->resolve({&sub, n.file});
        if (!inst.contains(key) && child.schema && child.schema->contains("default"))
          inst[key] = (*child.schema)["default"];
        if (inst.contains(key)) walk(child, inst[key]);
      }
    }
    if (inst.is_array() && s.contains("items"))
      for (auto& item : inst)
        walk({&s["items"], n.file}, item);
  };
  walk({&impl_->docs.at(file_of(kind)), file_of(kind)}, doc);
}

}  // namespace rosguard
