#pragma once
// The small JSON subset the calibration models are stored in (objects, arrays, numbers, strings,
// booleans, null). Numbers are written with 17 significant digits so that a model read back is
// bit-identical. Not a general JSON library: no \u escapes beyond ASCII, no streaming.

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace epmap::calibration::json {

struct Value {
  enum class Type { kNull, kBool, kNumber, kString, kArray, kObject };
  Type type = Type::kNull;
  bool boolean = false;
  double number = 0.0;
  std::string string;
  std::vector<Value> array;
  std::vector<std::pair<std::string, Value>> object;

  static Value Number(double v);
  static Value String(std::string v);
  static Value Bool(bool v);
  static Value Array(std::vector<Value> v = {});
  static Value Object();
  static Value Numbers(const double* v, int n);

  // Object access: Set appends or replaces; Get throws std::runtime_error naming the missing key.
  Value& Set(const std::string& key, Value v);
  const Value& Get(const std::string& key) const;
  const Value* Find(const std::string& key) const;

  // Typed reads that throw std::runtime_error with `what` in the message on a type mismatch.
  double AsNumber(const std::string& what) const;
  const std::string& AsString(const std::string& what) const;
  // An array of exactly n numbers.
  std::vector<double> AsNumbers(int n, const std::string& what) const;
};

std::string Write(const Value& v);
// Throws std::runtime_error with the offset and the problem on malformed text.
Value Parse(std::string_view text);

}  // namespace epmap::calibration::json
