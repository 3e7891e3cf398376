// A small JSON value, writer and reader for manifests (RFC 8259 subset: no surrogate-pair
// decoding beyond the BMP). Objects keep insertion order so written files are byte-stable.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace v2xloc::sim {

class Json {
 public:
  enum class Type { kNull, kBool, kNumber, kString, kArray, kObject };

  Json() = default;
  Json(std::nullptr_t) {}
  Json(bool b) : type_(Type::kBool), bool_(b) {}
  Json(int v) : type_(Type::kNumber), num_(v) {}
  Json(unsigned v) : type_(Type::kNumber), num_(v) {}
  Json(long v) : type_(Type::kNumber), num_(static_cast<double>(v)) {}
  Json(unsigned long v) : type_(Type::kNumber), num_(static_cast<double>(v)) {}
  Json(long long v) : type_(Type::kNumber), num_(static_cast<double>(v)) {}
  Json(unsigned long long v) : type_(Type::kNumber), num_(static_cast<double>(v)) {}
  Json(double v) : type_(Type::kNumber), num_(v) {}
  Json(const char* s) : type_(Type::kString), str_(s) {}
  Json(std::string s) : type_(Type::kString), str_(std::move(s)) {}

  static Json array() { Json j; j.type_ = Type::kArray; return j; }
  static Json object() { Json j; j.type_ = Type::kObject; return j; }
  template <typename T>
  static Json array_of(const std::vector<T>& values) {
    Json j = array();
    for (const auto& v : values) j.push(Json(v));
    return j;
  }

  Type type() const { return type_; }
  bool is_null() const { return type_ == Type::kNull; }
  bool is_number() const { return type_ == Type::kNumber; }
  bool is_string() const { return type_ == Type::kString; }
  bool is_array() const { return type_ == Type::kArray; }
  bool is_object() const { return type_ == Type::kObject; }

  // Accessors return a default for the wrong type (manifest readers check with has()/is_*()).
  bool as_bool(bool fallback = false) const { return type_ == Type::kBool ? bool_ : fallback; }
  double as_number(double fallback = 0.0) const { return type_ == Type::kNumber ? num_ : fallback; }
  int as_int(int fallback = 0) const { return type_ == Type::kNumber ? static_cast<int>(num_) : fallback; }
  const std::string& as_string() const { return str_; }

  // Arrays.
  Json& push(Json v);
  std::size_t size() const { return type_ == Type::kArray ? items_.size() : members_.size(); }
  const Json& operator[](std::size_t i) const;
  const std::vector<Json>& items() const { return items_; }
  std::vector<double> as_numbers() const;

  // Objects (insertion ordered; set() replaces an existing key).
  Json& set(const std::string& key, Json v);
  bool has(const std::string& key) const;
  const Json& operator[](const std::string& key) const;  // null Json if missing
  const std::vector<std::pair<std::string, Json>>& members() const { return members_; }

  // Serialization. indent < 0: compact. Numbers use the shortest round-trip form (%.17g fallback).
  std::string dump(int indent = 2) const;
  static bool parse(const std::string& text, Json& out, std::string& error);

 private:
  void dump_to(std::string& out, int indent, int depth) const;
  Type type_ = Type::kNull;
  bool bool_ = false;
  double num_ = 0.0;
  std::string str_;
  std::vector<Json> items_;
  std::vector<std::pair<std::string, Json>> members_;
};

bool read_json_file(const std::string& path, Json& out, std::string& error);
bool write_text_file(const std::string& path, const std::string& text, std::string& error);

}  // namespace v2xloc::sim
