#include "host_sim/common/json.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace v2xloc::sim {
namespace {

const Json& null_json() {
  static const Json kNull;
  return kNull;
}

void append_number(std::string& out, double v) {
  if (!std::isfinite(v)) {  // JSON has no NaN/Inf
    out += "null";
    return;
  }
  char buf[40];
  if (v == std::floor(v) && std::abs(v) < 1e15) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
  } else {
    // Shortest representation that round-trips (std::to_chars is exact and locale-free).
    auto res = std::to_chars(buf, buf + sizeof buf - 1, v);
    *res.ptr = '\0';
  }
  out += buf;
}

void append_string(std::string& out, const std::string& s) {
  out += '"';
  for (char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  out += '"';
}

class Parser {
 public:
  explicit Parser(const std::string& t) : t_(t) {}
  bool parse(Json& out, std::string& error) {
    if (!value(out, 0)) {
      error = "JSON parse error at offset " + std::to_string(pos_) + ": " + err_;
      return false;
    }
    skip_ws();
    if (pos_ != t_.size()) {
      error = "JSON: trailing characters at offset " + std::to_string(pos_);
      return false;
    }
    return true;
  }

 private:
  void skip_ws() {
    while (pos_ < t_.size() && (t_[pos_] == ' ' || t_[pos_] == '\n' || t_[pos_] == '\r' || t_[pos_] == '\t')) ++pos_;
  }
  bool fail(const char* m) { err_ = m; return false; }
  bool literal(const char* word) {
    std::size_t n = std::char_traits<char>::length(word);
    if (t_.compare(pos_, n, word) != 0) return fail("bad literal");
    pos_ += n;
    return true;
  }
  bool value(Json& out, int depth) {
    if (depth > 64) return fail("nesting too deep");
    skip_ws();
    if (pos_ >= t_.size()) return fail("unexpected end");
    const char c = t_[pos_];
    if (c == '{') return object(out, depth);
    if (c == '[') return array(out, depth);
    if (c == '"') {
      std::string s;
      if (!string(s)) return false;
      out = Json(std::move(s));
      return true;
    }
    if (c == 't') { out = Json(true); return literal("true"); }
    if (c == 'f') { out = Json(false); return literal("false"); }
    if (c == 'n') { out = Json(); return literal("null"); }
    return number(out);
  }
  bool number(Json& out) {
    const char* begin = t_.data() + pos_;
    const char* end = t_.data() + t_.size();
    double v = 0.0;
    auto res = std::from_chars(begin, end, v);
    if (res.ec != std::errc() || res.ptr == begin) return fail("bad number");
    pos_ += static_cast<std::size_t>(res.ptr - begin);
    out = Json(v);
    return true;
  }
  bool string(std::string& s) {
    ++pos_;  // opening quote
    while (pos_ < t_.size()) {
      const char c = t_[pos_++];
      if (c == '"') return true;
      if (c != '\\') { s += c; continue; }
      if (pos_ >= t_.size()) break;
      const char e = t_[pos_++];
      switch (e) {
        case '"': s += '"'; break;
        case '\\': s += '\\'; break;
        case '/': s += '/'; break;
        case 'b': s += '\b'; break;
        case 'f': s += '\f'; break;
        case 'n': s += '\n'; break;
        case 'r': s += '\r'; break;
        case 't': s += '\t'; break;
        case 'u': {
          if (pos_ + 4 > t_.size()) return fail("bad \\u escape");
          unsigned cp = 0;
          auto res = std::from_chars(t_.data() + pos_, t_.data() + pos_ + 4, cp, 16);
          if (res.ec != std::errc()) return fail("bad \\u escape");
          pos_ += 4;
          if (cp < 0x80) {
            s += static_cast<char>(cp);
          } else if (cp < 0x800) {
            s += static_cast<char>(0xC0 | (cp >> 6));
            s += static_cast<char>(0x80 | (cp & 0x3F));
          } else {
            s += static_cast<char>(0xE0 | (cp >> 12));
            s += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
            s += static_cast<char>(0x80 | (cp & 0x3F));
          }
          break;
        }
        default: return fail("bad escape");
      }
    }
    return fail("unterminated string");
  }
  bool array(Json& out, int depth) {
    out = Json::array();
    ++pos_;
    skip_ws();
    if (pos_ < t_.size() && t_[pos_] == ']') { ++pos_; return true; }
    while (true) {
      Json item;
      if (!value(item, depth + 1)) return false;
      out.push(std::move(item));
      skip_ws();
      if (pos_ >= t_.size()) return fail("unterminated array");
      if (t_[pos_] == ',') { ++pos_; continue; }
      if (t_[pos_] == ']') { ++pos_; return true; }
      return fail("expected , or ]");
    }
  }
  bool object(Json& out, int depth) {
    out = Json::object();
    ++pos_;
    skip_ws();
    if (pos_ < t_.size() && t_[pos_] == '}') { ++pos_; return true; }
    while (true) {
      skip_ws();
      if (pos_ >= t_.size() || t_[pos_] != '"') return fail("expected key");
      std::string key;
      if (!string(key)) return false;
      skip_ws();
      if (pos_ >= t_.size() || t_[pos_] != ':') return fail("expected :");
      ++pos_;
      Json v;
      if (!value(v, depth + 1)) return false;
      out.set(key, std::move(v));
      skip_ws();
      if (pos_ >= t_.size()) return fail("unterminated object");
      if (t_[pos_] == ',') { ++pos_; continue; }
      if (t_[pos_] == '}') { ++pos_; return true; }
      return fail("expected , or }");
    }
  }
  const std::string& t_;
  std::size_t pos_ = 0;
  std::string err_;
};

}  // namespace

Json& Json::push(Json v) {
  type_ = Type::kArray;
  items_.push_back(std::move(v));
  return items_.back();
}

const Json& Json::operator[](std::size_t i) const {
  return (type_ == Type::kArray && i < items_.size()) ? items_[i] : null_json();
}

std::vector<double> Json::as_numbers() const {
  std::vector<double> out;
  for (const auto& it : items_) out.push_back(it.as_number());
  return out;
}

Json& Json::set(const std::string& key, Json v) {
  type_ = Type::kObject;
  for (auto& [k, val] : members_) {
    if (k == key) { val = std::move(v); return val; }
  }
  members_.emplace_back(key, std::move(v));
  return members_.back().second;
}

bool Json::has(const std::string& key) const {
  for (const auto& m : members_) if (m.first == key) return true;
  return false;
}

const Json& Json::operator[](const std::string& key) const {
  for (const auto& m : members_) if (m.first == key) return m.second;
  return null_json();
}

void Json::dump_to(std::string& out, int indent, int depth) const {
  auto newline = [&](int d) {
    if (indent < 0) return;
    out += '\n';
    out.append(static_cast<std::size_t>(indent * d), ' ');
  };
  switch (type_) {
    case Type::kNull: out += "null"; break;
    case Type::kBool: out += bool_ ? "true" : "false"; break;
    case Type::kNumber: append_number(out, num_); break;
    case Type::kString: append_string(out, str_); break;
    case Type::kArray: {
      // Arrays of plain numbers stay on one line: poses and calibration matrices read better.
      bool flat = true;
      for (const auto& it : items_) flat = flat && (it.type_ == Type::kNumber || it.type_ == Type::kString);
      out += '[';
      for (std::size_t i = 0; i < items_.size(); ++i) {
        if (i) out += flat ? ", " : ",";
        if (!flat) newline(depth + 1);
        items_[i].dump_to(out, indent, depth + 1);
      }
      if (!flat && !items_.empty()) newline(depth);
      out += ']';
      break;
    }
    case Type::kObject: {
      out += '{';
      for (std::size_t i = 0; i < members_.size(); ++i) {
        if (i) out += ',';
        newline(depth + 1);
        append_string(out, members_[i].first);
        out += indent < 0 ? ":" : ": ";
        members_[i].second.dump_to(out, indent, depth + 1);
      }
      if (!members_.empty()) newline(depth);
      out += '}';
      break;
    }
  }
}

std::string Json::dump(int indent) const {
  std::string out;
  dump_to(out, indent, 0);
  if (indent >= 0) out += '\n';
  return out;
}

bool Json::parse(const std::string& text, Json& out, std::string& error) {
  return Parser(text).parse(out, error);
}

bool read_json_file(const std::string& path, Json& out, std::string& error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    error = "cannot open " + path;
    return false;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return Json::parse(ss.str(), out, error);
}

bool write_text_file(const std::string& path, const std::string& text, std::string& error) {
  std::ofstream out(path, std::ios::binary);
  if (!out) {
    error = "cannot write " + path;
    return false;
  }
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) {
    error = "write failed: " + path;
    return false;
  }
  return true;
}

}  // namespace v2xloc::sim
