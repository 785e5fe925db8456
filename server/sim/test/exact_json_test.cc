// Tests of server/json/exact_json.h (header-only; its test lives with the scenario
// reader, its first user, whose test program already has RapidJSON).

#include "server/json/exact_json.h"

#include <gtest/gtest.h>

#include <bit>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace hapticd::json {
namespace {

constexpr unsigned kFlags = rapidjson::kParseIterativeFlag;
constexpr unsigned kNanFlags = rapidjson::kParseIterativeFlag | rapidjson::kParseNanAndInfFlag;

// The single number of the JSON text "[token]", as ParseDocument reads it.
template <unsigned kParseFlags = kFlags>
rapidjson::Document ParseNumber(const std::string& token) {
  rapidjson::Document document;
  const rapidjson::ParseResult result = ParseDocument<kParseFlags>("[" + token + "]", document);
  EXPECT_FALSE(result.IsError()) << token << ": error " << result.Code() << " at " << result.Offset();
  if (result.IsError() || document.Size() != 1) document.SetArray().PushBack(0, document.GetAllocator());
  return document;
}

// The double "[token]" reads as; fails the test when it is not a double.
template <unsigned kParseFlags = kFlags>
double ParseDouble(const std::string& token) {
  const rapidjson::Document document = ParseNumber<kParseFlags>(token);
  EXPECT_TRUE(document[0].IsDouble()) << token;
  return document[0].GetDouble();
}

uint64_t Bits(double x) { return std::bit_cast<uint64_t>(x); }

// The error of parsing text: its code and offset.
std::pair<rapidjson::ParseErrorCode, size_t> ErrorOf(std::string_view text) {
  rapidjson::Document document;
  const rapidjson::ParseResult result = ParseDocument<kFlags>(text, document);
  return {result.Code(), result.Offset()};
}

// RapidJSON 1.1.0 read these as 4.06e31, -1.9e-267, ... (a zero significand through
// __builtin_clzll); each is exactly zero, of its sign.
TEST(ExactJson, ZerosWrittenWithAnExponentAreZero) {
  const std::string long_zero = "0." + std::string(41, '0');
  for (const std::string& zero : std::vector<std::string>{"0.0e50", "0e80", "0E+0", "0e-0", "0.0e-50", "0e308",
                                                          "0.000e-99999999999", long_zero, long_zero + "e40"}) {
    EXPECT_EQ(Bits(ParseDouble(zero)), Bits(0.0)) << zero;
    EXPECT_EQ(Bits(ParseDouble("-" + zero)), Bits(-0.0)) << zero;
  }
  EXPECT_EQ(Bits(ParseDouble("-0e-400")), Bits(-0.0));
  // a zero inside a document, beside its neighbours
  rapidjson::Document document;
  ASSERT_FALSE(ParseDocument<kFlags>(R"({"center": [0.0e50, 0, 3]})", document).IsError());
  EXPECT_EQ(Bits(document["center"][0].GetDouble()), Bits(0.0));
  EXPECT_TRUE(document["center"][1].IsInt());
  EXPECT_EQ(document["center"][2].GetInt(), 3);
}

// Hand-checked values, each against an independent spelling of the same double.
TEST(ExactJson, DoublesAreTheNearestDouble) {
  EXPECT_EQ(Bits(ParseDouble("0.1")), Bits(0x1.999999999999ap-4));
  EXPECT_EQ(Bits(ParseDouble("1.7976931348623157e308")), Bits(std::numeric_limits<double>::max()));
  EXPECT_EQ(Bits(ParseDouble("-1.7976931348623157e308")), Bits(-std::numeric_limits<double>::max()));
  // (the value that once hung Java's and PHP's parsers)
  EXPECT_EQ(Bits(ParseDouble("2.2250738585072014e-308")), Bits(std::numeric_limits<double>::min()));
  // subnormals exactly: 1e-320 is 2024 of the smallest
  const double tiny = std::numeric_limits<double>::denorm_min();
  EXPECT_EQ(Bits(ParseDouble("1e-320")), Bits(2024 * tiny));
  EXPECT_EQ(std::fpclassify(ParseDouble("1e-320")), FP_SUBNORMAL);
  EXPECT_EQ(Bits(ParseDouble("4.9406564584124654e-324")), Bits(tiny));
  EXPECT_EQ(Bits(ParseDouble("2.5e-324")), Bits(tiny));
  // below half the smallest subnormal: the signed zero it rounds to
  EXPECT_EQ(Bits(ParseDouble("2.4e-324")), Bits(0.0));
  EXPECT_EQ(Bits(ParseDouble("-1e-400")), Bits(-0.0));
  EXPECT_EQ(Bits(ParseDouble("0." + std::string(400, '0') + "1")), Bits(0.0));
  // many digits, and the exponent that brings them back
  EXPECT_EQ(Bits(ParseDouble("0." + std::string(500, '0') + "1e500")), Bits(0.1));
  EXPECT_EQ(Bits(ParseDouble("1.5e+2")), Bits(150.0));
  EXPECT_EQ(Bits(ParseDouble("1E2")), Bits(100.0));
}

// Every finite double printed with 17 significant digits reads back bit for bit.
TEST(ExactJson, SeventeenDigitsRoundTripRandomDoubles) {
  std::mt19937_64 random(20261202);
  std::uniform_real_distribution<double> unit(-1, 1);
  int tested = 0;
  for (int i = 0; i < 200000; ++i) {
    // random bit patterns (every exponent, subnormals included), and everyday magnitudes
    const double x = i % 2 == 0 ? std::bit_cast<double>(random()) : unit(random) * std::pow(10.0, i % 40 - 20);
    if (!std::isfinite(x) || x == 0) continue;
    char text[32];
    std::snprintf(text, sizeof(text), "%.17g", x);
    const rapidjson::Document document = ParseNumber(text);
    ASSERT_TRUE(document[0].IsNumber()) << text;
    ASSERT_EQ(Bits(document[0].GetDouble()), Bits(x)) << text;
    ++tested;
  }
  EXPECT_GT(tested, 190000);
}

// Integers keep RapidJSON's own types and values (RapidJSON's integer reading is not
// the bug: its plain parse is the oracle).
TEST(ExactJson, IntegersKeepRapidJsonsTypes) {
  std::vector<std::string> tokens = {"0",          "-0",          "1",           "-1",
                                     "2147483647", "2147483648",  "-2147483648", "-2147483649",
                                     "4294967295", "4294967296",  "9007199254740993",
                                     "-9223372036854775808",      "-9223372036854775809",
                                     "9223372036854775807",       "9223372036854775808",
                                     "18446744073709551615",      "18446744073709551616",
                                     "123456789012345678901234567890"};
  std::mt19937_64 random(7);
  for (int i = 0; i < 2000; ++i) {
    const uint64_t n = random() >> (i % 64);
    tokens.push_back(std::to_string(n));
    tokens.push_back(std::to_string(static_cast<int64_t>(n)));
  }
  for (const std::string& token : tokens) {
    rapidjson::Document oracle;
    oracle.Parse(token.c_str());
    ASSERT_FALSE(oracle.HasParseError()) << token;
    const rapidjson::Document document = ParseNumber(token);
    const rapidjson::Value& n = document[0];
    EXPECT_EQ(n.IsInt(), oracle.IsInt()) << token;
    EXPECT_EQ(n.IsUint(), oracle.IsUint()) << token;
    EXPECT_EQ(n.IsInt64(), oracle.IsInt64()) << token;
    EXPECT_EQ(n.IsUint64(), oracle.IsUint64()) << token;
    EXPECT_EQ(n.IsDouble(), oracle.IsDouble()) << token;
    if (oracle.IsInt64()) {
      EXPECT_EQ(n.GetInt64(), oracle.GetInt64()) << token;
    }
    if (oracle.IsUint64()) {
      EXPECT_EQ(n.GetUint64(), oracle.GetUint64()) << token;
    }
  }
  // and by hand: 2^53 + 1, -2^63 and 2^64 - 1 stay exact integers
  EXPECT_EQ(ParseNumber("9007199254740993")[0].GetUint64(), (uint64_t{1} << 53) + 1);
  EXPECT_FALSE(ParseNumber("9007199254740993")[0].IsDouble());
  EXPECT_TRUE(ParseNumber("-9223372036854775808")[0].IsInt64());
  EXPECT_EQ(ParseNumber("-9223372036854775808")[0].GetInt64(), std::numeric_limits<int64_t>::min());
  EXPECT_TRUE(ParseNumber("18446744073709551615")[0].IsUint64());
  EXPECT_FALSE(ParseNumber("18446744073709551615")[0].IsInt64());
  EXPECT_EQ(ParseNumber("18446744073709551615")[0].GetUint64(), std::numeric_limits<uint64_t>::max());
  // past 64 bits: the nearest double, 2^64
  EXPECT_EQ(Bits(ParseDouble("18446744073709551616")), Bits(0x1p64));
  EXPECT_EQ(Bits(ParseDouble("-9223372036854775809")), Bits(-0x1p63));
}

// A magnitude past the largest double is refused as RapidJSON refuses 1e400, at the
// number's first byte (RapidJSON 1.1.0 read 9e308 as -2.8e-308 and 1.8e308 as NaN).
TEST(ExactJson, NumbersPastTheLargestDoubleAreRefused) {
  using Error = std::pair<rapidjson::ParseErrorCode, size_t>;
  const Error too_big = {rapidjson::kParseErrorNumberTooBig, 1};
  EXPECT_EQ(ErrorOf("[9e308]"), too_big);
  EXPECT_EQ(ErrorOf("[1.8e308]"), too_big);
  EXPECT_EQ(ErrorOf("[-1.7976931348623159e308]"), too_big);
  EXPECT_EQ(ErrorOf("[0.01e311]"), too_big);
  // those RapidJSON's scanner refuses by their exponent, as before (0e400 too: it
  // refuses before any value is known)
  EXPECT_EQ(ErrorOf("[1e400]"), too_big);
  EXPECT_EQ(ErrorOf("[0e400]"), too_big);
  // the last ones that round down to the largest double are values
  EXPECT_EQ(Bits(ParseDouble("1.7976931348623158e308")), Bits(std::numeric_limits<double>::max()));
  EXPECT_EQ(Bits(ParseDouble("0.001e311")), Bits(1e308));
  // at its place in a document
  EXPECT_EQ(ErrorOf(R"({"a": [1, 2, 9e308]})"), Error(rapidjson::kParseErrorNumberTooBig, 13));
}

// With kParseNanAndInfFlag, NaN and the infinities read as before; the spellings
// RapidJSON scans but has no value for are invalid (RapidJSON 1.1.0 read "NaN.5" as 0.5).
TEST(ExactJson, NanAndInfinityWhereAllowed) {
  EXPECT_TRUE(std::isnan(ParseDouble<kNanFlags>("NaN")));
  EXPECT_TRUE(std::isnan(ParseDouble<kNanFlags>("-NaN")));
  EXPECT_EQ(ParseDouble<kNanFlags>("Infinity"), std::numeric_limits<double>::infinity());
  EXPECT_EQ(ParseDouble<kNanFlags>("-Infinity"), -std::numeric_limits<double>::infinity());
  EXPECT_EQ(ParseDouble<kNanFlags>("Inf"), std::numeric_limits<double>::infinity());
  EXPECT_EQ(ParseDouble<kNanFlags>("-Inf"), -std::numeric_limits<double>::infinity());
  for (const char* text : {"[NaN.5]", "[Infe3]", "[-Infinity.0]"}) {
    rapidjson::Document document;
    const rapidjson::ParseResult result = ParseDocument<kNanFlags>(text, document);
    EXPECT_EQ(result.Code(), rapidjson::kParseErrorValueInvalid) << text;
    EXPECT_EQ(result.Offset(), 1u) << text;
  }
  // without the flag they are no JSON at all, as RapidJSON says
  EXPECT_EQ(ErrorOf("[NaN]"), std::make_pair(rapidjson::kParseErrorValueInvalid, size_t{1}));
}

// Syntax errors keep RapidJSON's code and offset (its plain parse is the oracle: none
// of these gets as far as a number's value).
TEST(ExactJson, SyntaxErrorsAreRapidJsons) {
  for (const char* text : {"", "[", "[1,]", "[01]", "[1.]", "[1.e5]", "[1e]", "[1e+]", "[-]", "[--1]", "[+1]",
                           "[.5]", "[1 2]", "{\"a\" 1}", "{\"a\": tru}", "{\"a\": 1,}", "\"\\u12\"", "[1] x",
                           "{\"a\": [0.0e50, }", "[1e400, x]"}) {
    rapidjson::Document oracle;
    oracle.Parse<kFlags>(text);
    ASSERT_TRUE(oracle.HasParseError()) << text;
    EXPECT_EQ(ErrorOf(text), std::make_pair(oracle.GetParseError(), oracle.GetErrorOffset())) << text;
  }
  // a failed parse leaves the document as it was
  rapidjson::Document document;
  document.SetObject();
  EXPECT_TRUE(ParseDocument<kFlags>("[1, 2", document).IsError());
  EXPECT_TRUE(document.IsObject());
}

// ParseEvents sends a handler RapidJSON's typed events, never a RawNumber.
TEST(ExactJson, EventsCarryTypedNumbers) {
  struct Recorder : rapidjson::BaseReaderHandler<rapidjson::UTF8<>, Recorder> {
    std::vector<std::string> events;
    bool Int(int i) { return Add("int " + std::to_string(i)); }
    bool Uint(unsigned i) { return Add("uint " + std::to_string(i)); }
    bool Int64(int64_t i) { return Add("int64 " + std::to_string(i)); }
    bool Uint64(uint64_t i) { return Add("uint64 " + std::to_string(i)); }
    bool Double(double d) { return Add("double " + std::to_string(d)); }
    bool RawNumber(const char*, rapidjson::SizeType, bool) { return Add("raw"); }
    bool Default() { return Add("other"); }
    bool Add(std::string event) {
      events.push_back(std::move(event));
      return true;
    }
  };
  Recorder recorder;
  ASSERT_FALSE(ParseEvents<kFlags>("[-1, 1, 5000000000, -5000000000, 0.0e50, 2.5]", recorder).IsError());
  EXPECT_EQ(recorder.events,
            (std::vector<std::string>{"other", "int -1", "uint 1", "uint64 5000000000", "int64 -5000000000",
                                      "double 0.000000", "double 2.500000", "other"}));
}

}  // namespace
}  // namespace hapticd::json
