#pragma once

// Parsing JSON with every number read exactly. Scene files, scenarios, --set overrides
// and conformance cases are all parsed here. Header-only, like RapidJSON itself.
//
// Theory of operation. RapidJSON 1.1.0's own number conversion is wrong on some input:
// with kParseFullPrecisionFlag a zero written with an exponent ("0.0e50", "0e80", or a
// zero of more than 22 digits) goes through DiyFp::Normalize of a zero significand,
// __builtin_clzll(0), and comes out as garbage (4.06e31, -1.9e-267); a number past
// the largest double ("9e308") comes out as NaN or a tiny negative number
// (Tencent/rapidjson#1249 and #1441, fixed upstream after 1.1.0). So RapidJSON here
// only scans: with kParseNumbersAsStringsFlag each number reaches the handler as its
// text (RawNumber), and ExactNumbers turns that text into the event RapidJSON would
// have sent, with the value std::from_chars gives (correctly rounded):
//
//   text --Reader<flags | NumbersAsStrings>--> events --ExactNumbers--> handler
//                                 RawNumber("0.0e50") ---> Double(0.0)
//
// The scanner is RapidJSON's, so syntax errors keep their codes and offsets, and
// numbers it refuses (1e400, and so also 0e400: its exponent check comes before any
// value) stay refused as before.

#include <rapidjson/document.h>
#include <rapidjson/encodedstream.h>
#include <rapidjson/error/error.h>
#include <rapidjson/memorystream.h>
#include <rapidjson/reader.h>

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <limits>
#include <string_view>
#include <system_error>
#include <variant>

namespace hapticd::json {

// A number's value, in the type RapidJSON gives it: an integer in [0, 2^32) is
// unsigned, one in [-2^31, 0) int, the rest of [0, 2^64) uint64_t, of [-2^63, 0)
// int64_t ("-0" is the int 0); every other number is a double.
using Number = std::variant<unsigned, int, uint64_t, int64_t, double>;

// ReadNumberToken's answer: the value, or why the token has none.
struct NumberValue {
  Number value;  // when error is kParseErrorNone
  rapidjson::ParseErrorCode error = rapidjson::kParseErrorNone;
};

namespace internal {

// The decimal exponent of the first non-zero digit of a number token (1 for "12.5",
// -3 for "0.0012", 5 for "1e5"), the exponent saturated well past double's range; 0
// when the token is zero. It tells a number too big for a double from one too small.
inline int64_t LeadingDigitExponent(std::string_view token) {
  constexpr int64_t kSaturated = 100000;
  size_t i = token.starts_with('-') ? 1 : 0;
  const auto is_digit = [&](size_t k) { return k < token.size() && token[k] >= '0' && token[k] <= '9'; };
  // the integer part: no leading zeros in JSON, so a non-zero one starts with its first digit
  const size_t integer_start = i;
  while (is_digit(i)) ++i;
  bool nonzero = !(i - integer_start == 1 && token[integer_start] == '0');
  int64_t exponent = static_cast<int64_t>(i - integer_start) - 1;
  // the fraction: the first non-zero digit, when the integer part is zero
  if (i < token.size() && token[i] == '.') {
    const size_t fraction_start = ++i;
    for (; is_digit(i); ++i) {
      if (!nonzero && token[i] != '0') {
        nonzero = true;
        exponent = -static_cast<int64_t>(i - fraction_start + 1);
      }
    }
  }
  if (!nonzero) return 0;
  // the exponent, saturated
  if (i < token.size() && (token[i] == 'e' || token[i] == 'E')) {
    ++i;
    const bool minus = i < token.size() && token[i] == '-';
    if (i < token.size() && (token[i] == '-' || token[i] == '+')) ++i;
    int64_t e = 0;
    for (; is_digit(i); ++i) e = std::min(kSaturated, e * 10 + (token[i] - '0'));
    exponent += minus ? -e : e;
  }
  return exponent;
}

}  // namespace internal

// The value of a number token, text that RapidJSON's scanner accepted as a number:
// -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?, or with kParseNanAndInfFlag -?NaN,
// -?Inf, -?Infinity (NaN's sign is dropped, as RapidJSON drops it). Integers keep
// RapidJSON's types (Number); the rest is the double nearest the decimal value, ties
// to even: subnormals are exact, and what is below half the smallest subnormal is ±0.
// Errors: kParseErrorNumberTooBig when the magnitude rounds past the largest double,
// 1.7976931348623157e308 (RapidJSON's code for 1e400); kParseErrorValueInvalid for a
// NaN or Infinity with a fraction or an exponent ("NaN.5", "Infe3", which RapidJSON
// 1.1.0 scans, and reads as 0.5 and 0).
inline NumberValue ReadNumberToken(std::string_view token) {
  const bool minus = token.starts_with('-');
  const std::string_view magnitude = token.substr(minus ? 1 : 0);
  // NaN and the infinities: only their exact spellings
  if (magnitude.starts_with('N') || magnitude.starts_with('I')) {
    if (magnitude == "NaN") return {std::numeric_limits<double>::quiet_NaN()};
    constexpr double kInfinity = std::numeric_limits<double>::infinity();
    if (magnitude == "Inf" || magnitude == "Infinity") return {minus ? -kInfinity : kInfinity};
    return {0.0, rapidjson::kParseErrorValueInvalid};
  }
  // an integer within 64 bits: RapidJSON's integer types
  if (magnitude.find_first_of(".eE") == std::string_view::npos) {
    uint64_t n = 0;
    const auto [end, error] = std::from_chars(magnitude.data(), magnitude.data() + magnitude.size(), n);
    if (error == std::errc() && end == magnitude.data() + magnitude.size()) {
      if (!minus) {
        if (n <= std::numeric_limits<unsigned>::max()) return {static_cast<unsigned>(n)};
        return {n};
      }
      // -n, by two's complement as RapidJSON negates (n = 2^31 or 2^63 is the minimum)
      if (n <= uint64_t{1} << 31) return {static_cast<int>(static_cast<int64_t>(~n + 1))};
      if (n <= uint64_t{1} << 63) return {static_cast<int64_t>(~n + 1)};
    }
    // else a double, as RapidJSON makes one of a longer integer
  }
  // a double, correctly rounded
  double x = 0;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), x);
  if (error == std::errc() && end == token.data() + token.size()) return {x};
  // out of range: too big (refused), or below the smallest subnormal (a signed zero)
  if (error == std::errc::result_out_of_range) {
    if (internal::LeadingDigitExponent(token) > 0) return {0.0, rapidjson::kParseErrorNumberTooBig};
    return {minus ? -0.0 : 0.0};
  }
  return {0.0, rapidjson::kParseErrorValueInvalid};
}

// A SAX handler that forwards every event to handler, with each RawNumber turned into
// the number event of its value (ReadNumberToken). On a number without a value it
// stops the parse and keeps the reason in error().
template <typename Handler>
class ExactNumbers {
 public:
  explicit ExactNumbers(Handler& handler) : handler_(handler) {}

  bool Null() { return handler_.Null(); }
  bool Bool(bool b) { return handler_.Bool(b); }
  bool Int(int i) { return handler_.Int(i); }
  bool Uint(unsigned i) { return handler_.Uint(i); }
  bool Int64(int64_t i) { return handler_.Int64(i); }
  bool Uint64(uint64_t i) { return handler_.Uint64(i); }
  bool Double(double d) { return handler_.Double(d); }
  bool RawNumber(const char* text, rapidjson::SizeType length, bool) {
    const NumberValue number = ReadNumberToken(std::string_view(text, length));
    if (number.error != rapidjson::kParseErrorNone) {
      error_ = number.error;
      return false;
    }
    return std::visit([this](auto value) { return this->Send(value); }, number.value);
  }
  bool String(const char* text, rapidjson::SizeType length, bool copy) { return handler_.String(text, length, copy); }
  bool StartObject() { return handler_.StartObject(); }
  bool Key(const char* text, rapidjson::SizeType length, bool copy) { return handler_.Key(text, length, copy); }
  bool EndObject(rapidjson::SizeType members) { return handler_.EndObject(members); }
  bool StartArray() { return handler_.StartArray(); }
  bool EndArray(rapidjson::SizeType elements) { return handler_.EndArray(elements); }

  // Why a number stopped the parse; kParseErrorNone if none did.
  rapidjson::ParseErrorCode error() const { return error_; }

 private:
  bool Send(unsigned i) { return handler_.Uint(i); }
  bool Send(int i) { return handler_.Int(i); }
  bool Send(uint64_t i) { return handler_.Uint64(i); }
  bool Send(int64_t i) { return handler_.Int64(i); }
  bool Send(double d) { return handler_.Double(d); }

  Handler& handler_;
  rapidjson::ParseErrorCode error_ = rapidjson::kParseErrorNone;
};

// Parses text (UTF-8; a leading BOM is skipped, as Document::Parse skips it) with
// RapidJSON's flags kFlags, sending the events to handler with every number exact.
// Returns RapidJSON's error code and byte offset, as Document::Parse reports them; a
// number ReadNumberToken refuses is reported with its code at the number's first byte.
// kFlags must not ask for in-situ parsing or RapidJSON's own number conversion.
template <unsigned kFlags, typename Handler>
rapidjson::ParseResult ParseEvents(std::string_view text, Handler& handler) {
  static_assert((kFlags & (rapidjson::kParseInsituFlag | rapidjson::kParseFullPrecisionFlag)) == 0,
                "numbers are converted here: no in-situ parse, no RapidJSON precision flag");
  ExactNumbers<Handler> exact(handler);
  rapidjson::MemoryStream memory(text.data(), text.size());
  rapidjson::EncodedInputStream<rapidjson::UTF8<>, rapidjson::MemoryStream> stream(memory);
  rapidjson::Reader reader;
  rapidjson::ParseResult result = reader.Parse<kFlags | rapidjson::kParseNumbersAsStringsFlag>(stream, exact);
  // a number without a value stopped the parse (kParseErrorTermination, at its start)
  if (exact.error() != rapidjson::kParseErrorNone) result.Set(exact.error(), result.Offset());
  return result;
}

// Parses text into document as ParseEvents reads it. On an error the document is left
// as it was, and the error is returned (document.HasParseError() does not tell it).
template <unsigned kFlags>
rapidjson::ParseResult ParseDocument(std::string_view text, rapidjson::Document& document) {
  rapidjson::ParseResult result;
  auto generate = [&](rapidjson::Document& handler) {
    result = ParseEvents<kFlags>(text, handler);
    return !result.IsError();
  };
  document.Populate(generate);
  return result;
}

}  // namespace hapticd::json
