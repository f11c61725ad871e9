// JSON Schema validation and defaults for scenario, platform and workload documents.
//
// The schema files under scenarios/schema/ are the single source of truth for the structure of
// these documents: valijson checks documents against them, errors are rendered from the schema
// node at the failing path (allowed keys, enum values, ranges), and defaults come from their
// "default" annotations. Contract: load once, then use from one thread at a time.
#pragma once

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace rosguard {

enum class SchemaKind { Scenario, Platform, Workload, Guard };

class SchemaSet {
 public:
  // Loads scenario/platform/workload/guard.schema.json from `dir`. Throws RunError when missing.
  explicit SchemaSet(const std::filesystem::path& dir);
  ~SchemaSet();
  SchemaSet(const SchemaSet&) = delete;
  SchemaSet& operator=(const SchemaSet&) = delete;

  // Throws InputError(file, JSON pointer, message) for the first problem found; when there are
  // more, the message says how many.
  void validate(const nlohmann::json& doc, SchemaKind kind, const std::string& file) const;

  // Inserts the schema's "default" for every missing key (recursively; inserted objects get
  // their own defaults too).
  void apply_defaults(nlohmann::json& doc, SchemaKind kind) const;

  // Every validation problem of `doc` as (JSON pointer, message); empty when valid.
  std::vector<std::pair<std::string, std::string>> errors(const nlohmann::json& doc,
                                                          SchemaKind kind) const;
  // The first problem, its message ending "(and N more problems)"; nullopt when valid.
  std::optional<std::pair<std::string, std::string>> first_error(const nlohmann::json& doc,
                                                                 SchemaKind kind) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rosguard
