// An immutable JSON document shared by every copy (a platform's or a workload's document is
// held by each of a sweep's points: with 10,000 points one copy each made the runner's process
// hundreds of MB, and every sim task forks that process). Reads forward to the document;
// assigning a json replaces the shared document for this copy only.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "core/hash.h"

namespace rosguard {

class SharedJson {
 public:
  SharedJson() : doc_(empty()) {}
  SharedJson(nlohmann::json doc)  // NOLINT(google-explicit-constructor): a json is one
      : doc_(std::make_shared<const nlohmann::json>(std::move(doc))), text_(compact(*doc_)) {}

  // As json's own: {{"key", value}, ...} builds an object.
  SharedJson(std::initializer_list<nlohmann::detail::json_ref<nlohmann::json>> init)
      : SharedJson(nlohmann::json(init)) {}

  const nlohmann::json& get() const { return *doc_; }
  operator const nlohmann::json&() const { return *doc_; }  // NOLINT(google-explicit-constructor)
  const nlohmann::json* operator->() const { return doc_.get(); }

  template <class K>
  bool contains(K&& key) const {
    return doc_->contains(std::forward<K>(key));
  }
  template <class K>
  const nlohmann::json& at(K&& key) const {
    return doc_->at(std::forward<K>(key));
  }
  template <class K>
  const nlohmann::json& operator[](K&& key) const {
    return (*doc_)[std::forward<K>(key)];
  }
  template <class K, class V>
  auto value(K&& key, V&& fallback) const {
    return doc_->value(std::forward<K>(key), std::forward<V>(fallback));
  }
  auto items() const { return doc_->items(); }
  // dump() without indent is made once, when the document is (Baselines::key hashes the
  // platform's and the workload's for every row of a run).
  std::string dump(int indent = -1) const {
    return indent == -1 && text_ ? text_->text : doc_->dump(indent);
  }
  // fnv1a(dump()), also made once: keys that name a document (Baselines::key, the platform's
  // 8 KB for every row) hash this instead of its text.
  std::uint64_t hash() const { return text_ ? text_->hash : fnv1a(doc_->dump()); }

  friend bool operator==(const SharedJson& a, const SharedJson& b) {
    return a.doc_ == b.doc_ || *a.doc_ == *b.doc_;
  }
  friend bool operator==(const SharedJson& a, const nlohmann::json& b) { return *a.doc_ == b; }

 private:
  static const std::shared_ptr<const nlohmann::json>& empty() {
    static const auto e = std::make_shared<const nlohmann::json>();
    return e;
  }
  struct Text {
    std::string text;    // doc_->dump()
    std::uint64_t hash;  // fnv1a(text)
  };
  // Null when dump() throws (a string that is not UTF-8): dump() then throws as json's does.
  static std::shared_ptr<const Text> compact(const nlohmann::json& doc) {
    try {
      std::string text = doc.dump();
      const std::uint64_t hash = fnv1a(text);
      return std::make_shared<const Text>(Text{std::move(text), hash});
    } catch (const nlohmann::json::exception&) {
      return nullptr;
    }
  }
  std::shared_ptr<const nlohmann::json> doc_;
  std::shared_ptr<const Text> text_;  // null: dump() made on each call
};

}  // namespace rosguard
