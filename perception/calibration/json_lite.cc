#include "perception/calibration/json_lite.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace epmap::calibration::json {

Value Value::Number(double v) {
  Value r;
  r.type = Type::kNumber;
  r.number = v;
  return r;
}
Value Value::String(std::string v) {
  Value r;
  r.type = Type::kString;
  r.string = std::move(v);
  return r;
}
Value Value::Bool(bool v) {
  Value r;
  r.type = Type::kBool;
  r.boolean = v;
  return r;
}
Value Value::Array(std::vector<Value> v) {
  Value r;
  r.type = Type::kArray;
  r.array = std::move(v);
  return r;
}
Value Value::Object() {
  Value r;
  r.type = Type::kObject;
  return r;
}
Value Value::Numbers(const double* v, int n) {
  Value r = Array();
  for (int i = 0; i < n; ++i) r.array.push_back(Number(v[i]));
  return r;
}

Value& Value::Set(const std::string& key, Value v) {
  for (auto& [k, existing] : object) {
    if (k == key) {
      existing = std::move(v);
      return existing;
    }
  }
  object.emplace_back(key, std::move(v));
  return object.back().second;
}

const Value* Value::Find(const std::string& key) const {
  if (type != Type::kObject) return nullptr;
  for (const auto& [k, v] : object) {
    if (k == key) return &v;
  }
  return nullptr;
}

const Value& Value::Get(const std::string& key) const {
  const Value* v = Find(key);
  if (!v) throw std::runtime_error("JSON: missing key '" + key + "'");
  return *v;
}

double Value::AsNumber(const std::string& what) const {
  if (type != Type::kNumber) throw std::runtime_error("JSON: '" + what + "' must be a number");
  return number;
}

const std::string& Value::AsString(const std::string& what) const {
  if (type != Type::kString) throw std::runtime_error("JSON: '" + what + "' must be a string");
  return string;
}

std::vector<double> Value::AsNumbers(int n, const std::string& what) const {
  if (type != Type::kArray || static_cast<int>(array.size()) != n) {
    throw std::runtime_error("JSON: '" + what + "' must be an array of " + std::to_string(n) +
                             " numbers");
  }
  std::vector<double> out;
  for (const auto& v : array) out.push_back(v.AsNumber(what));
  return out;
}

namespace {

void WriteString(const std::string& s, std::string& out) {
  out.push_back('"');
  for (char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        out.push_back(c);
    }
  }
  out.push_back('"');
}

void WriteValue(const Value& v, std::string& out) {
  switch (v.type) {
    case Value::Type::kNull:
      out += "null";
      break;
    case Value::Type::kBool:
      out += v.boolean ? "true" : "false";
      break;
    case Value::Type::kNumber: {
      if (!std::isfinite(v.number)) {
        out += "null";  // JSON has no NaN/inf; readers see a missing value
        break;
      }
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.17g", v.number);
      out += buf;
      break;
    }
    case Value::Type::kString:
      WriteString(v.string, out);
      break;
    case Value::Type::kArray:
      out.push_back('[');
      for (size_t i = 0; i < v.array.size(); ++i) {
        if (i) out.push_back(',');
        WriteValue(v.array[i], out);
      }
      out.push_back(']');
      break;
    case Value::Type::kObject:
      out.push_back('{');
      for (size_t i = 0; i < v.object.size(); ++i) {
        if (i) out.push_back(',');
        WriteString(v.object[i].first, out);
        out.push_back(':');
        WriteValue(v.object[i].second, out);
      }
      out.push_back('}');
      break;
  }
}

class Parser {
 public:
  explicit Parser(std::string_view text) : s_(text) {}

  Value ParseDocument() {
    Value v = ParseValue(0);
    SkipSpace();
    if (pos_ != s_.size()) Fail("trailing characters after the JSON value");
    return v;
  }

 private:
  [[noreturn]] void Fail(const std::string& what) const {
    throw std::runtime_error("JSON parse error at offset " + std::to_string(pos_) + ": " + what);
  }
  void SkipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  bool Consume(char c) {
    SkipSpace();
    if (pos_ < s_.size() && s_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  void Expect(char c) {
    if (!Consume(c)) Fail(std::string("expected '") + c + "'");
  }
  bool ConsumeWord(std::string_view w) {
    if (s_.substr(pos_, w.size()) == w) {
      pos_ += w.size();
      return true;
    }
    return false;
  }

  std::string ParseString() {
    Expect('"');
    std::string out;
    while (pos_ < s_.size() && s_[pos_] != '"') {
      char c = s_[pos_++];
      if (c == '\\') {
        if (pos_ >= s_.size()) Fail("unterminated escape");
        const char e = s_[pos_++];
        switch (e) {
          case 'n':
            out.push_back('\n');
            break;
          case 't':
            out.push_back('\t');
            break;
          case '"':
          case '\\':
          case '/':
            out.push_back(e);
            break;
          default:
            Fail(std::string("unsupported escape \\") + e);
        }
      } else {
        out.push_back(c);
      }
    }
    if (pos_ >= s_.size()) Fail("unterminated string");
    ++pos_;
    return out;
  }

  Value ParseValue(int depth) {
    if (depth > 64) Fail("nesting too deep");
    SkipSpace();
    if (pos_ >= s_.size()) Fail("unexpected end of text");
    const char c = s_[pos_];
    if (c == '{') {
      ++pos_;
      Value obj = Value::Object();
      if (Consume('}')) return obj;
      do {
        SkipSpace();
        std::string key = ParseString();
        Expect(':');
        obj.Set(key, ParseValue(depth + 1));
      } while (Consume(','));
      Expect('}');
      return obj;
    }
    if (c == '[') {
      ++pos_;
      Value arr = Value::Array();
      if (Consume(']')) return arr;
      do {
        arr.array.push_back(ParseValue(depth + 1));
      } while (Consume(','));
      Expect(']');
      return arr;
    }
    if (c == '"') return Value::String(ParseString());
    if (ConsumeWord("true")) return Value::Bool(true);
    if (ConsumeWord("false")) return Value::Bool(false);
    if (ConsumeWord("null")) return Value();
    // A number: strtod on a bounded copy (string_view is not null-terminated).
    size_t end = pos_;
    while (end < s_.size() &&
           (std::isdigit(static_cast<unsigned char>(s_[end])) || s_[end] == '-' || s_[end] == '+' ||
            s_[end] == '.' || s_[end] == 'e' || s_[end] == 'E')) {
      ++end;
    }
    if (end == pos_) Fail(std::string("unexpected character '") + c + "'");
    const std::string token(s_.substr(pos_, end - pos_));
    char* parsed_end = nullptr;
    const double v = std::strtod(token.c_str(), &parsed_end);
    if (parsed_end != token.c_str() + token.size()) Fail("malformed number '" + token + "'");
    pos_ = end;
    return Value::Number(v);
  }

  std::string_view s_;
  size_t pos_ = 0;
};

}  // namespace

std::string Write(const Value& v) {
  std::string out;
  WriteValue(v, out);
  return out;
}

Value Parse(std::string_view text) {
  return Parser(text).ParseDocument();
}

}  // namespace epmap::calibration::json
