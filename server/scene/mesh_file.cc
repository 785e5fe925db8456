#include "server/scene/mesh_file.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <type_traits>

#include "server/scene/value_text.h"

namespace hapticd::scene {
namespace {

using geometry::Vector3;

// A part of a message as text: strings as they are, numbers in their exact shortest form.
std::string Text(std::string_view text) { return std::string(text); }
template <typename Number>
  requires std::is_arithmetic_v<Number>
std::string Text(Number value) {
  if constexpr (std::is_floating_point_v<Number>) {
    return FormatExact(static_cast<double>(value));
  } else {
    return std::to_string(value);
  }
}

// pattern with each "{}" replaced by the next argument's Text (the scene library does
// not link fmt).
template <typename... Args>
std::string Format(std::string_view pattern, const Args&... args) {
  const std::string parts[] = {Text(args)..., ""};
  std::string message;
  size_t next = 0;
  for (size_t i = 0; i < pattern.size(); ++i) {
    if (pattern.compare(i, 2, "{}") == 0 && next < sizeof...(Args)) {
      message += parts[next++];
      ++i;
    } else {
      message += pattern[i];
    }
  }
  return message;
}

// One whitespace-separated word of a text file and the line it is on (1-based).
struct Token {
  std::string_view text;
  int line = 0;
};

// Splits one line (without its end-of-line) into words; '#' starts a comment when
// strip_comments.
std::vector<std::string_view> SplitWords(std::string_view line, bool strip_comments) {
  if (strip_comments) line = line.substr(0, line.find('#'));
  std::vector<std::string_view> words;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    size_t j = i;
    while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
    if (j > i) words.push_back(line.substr(i, j - i));
    i = j;
  }
  return words;
}

// Calls on_line(words, line_number) for every line of text ('\n' or "\r\n" ends).
template <typename OnLine>
void ForEachLine(std::string_view text, bool strip_comments, OnLine on_line) {
  int line_number = 0;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    ++line_number;
    on_line(SplitWords(text.substr(start, end - start), strip_comments), line_number);
    start = end + 1;
  }
}

// A finite number from a whole word ("+1.5" allowed); throws naming name:line.
double ParseCoordinate(std::string_view word, std::string_view name, int line) {
  std::string_view digits = word;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  double value = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (error != std::errc() || end != digits.data() + digits.size()) {
    throw MeshFileError(Format("{}:{}: '{}' is not a number", name, line, word));
  }
  if (!std::isfinite(value)) {
    throw MeshFileError(Format("{}:{}: coordinate '{}' is not a finite number", name, line, word));
  }
  return value;
}

// A face corner of an OBJ file: its vertex index (0-based; a positive index as written
// may name a vertex defined later, so it is checked at the end) and its line.
struct ObjCorner {
  int64_t index = 0;
  int line = 0;
};

// The vertex index (0-based) of an OBJ corner word "i", "i/t", "i//n" or "i/t/n".
int ResolveObjIndex(std::string_view word, size_t vertices_so_far, std::string_view name, int line) {
  const std::string_view index_text = word.substr(0, word.find('/'));
  int64_t index = 0;
  const auto [end, error] =
      std::from_chars(index_text.data(), index_text.data() + index_text.size(), index);
  if (error != std::errc() || end != index_text.data() + index_text.size()) {
    throw MeshFileError(Format("{}:{}: face corner '{}' has no valid vertex index", name, line, word));
  }
  // 0 is no index in OBJ
  if (index == 0) {
    throw MeshFileError(Format("{}:{}: face index 0 is invalid (OBJ indices start at 1)", name, line));
  }
  // negative: counted back from the last vertex defined so far
  if (index < 0) {
    if (static_cast<uint64_t>(-index) > vertices_so_far) {
      throw MeshFileError(Format(
          "{}:{}: face index {} reaches {} vertices back, but only {} are defined before this line",
          name, line, index, -index, vertices_so_far));
    }
    return static_cast<int>(static_cast<int64_t>(vertices_so_far) + index);
  }
  if (index > std::numeric_limits<int>::max()) {
    throw MeshFileError(Format("{}:{}: face index {} is too large", name, line, index));
  }
  return static_cast<int>(index - 1);
}

// Index of position p in data, adding it when no vertex is exactly there yet.
int InternVertex(const Vector3& p, std::map<std::array<double, 3>, int>& index_of, MeshData& data) {
  const auto [it, added] =
      index_of.try_emplace({p.x(), p.y(), p.z()}, static_cast<int>(data.vertices.size()));
  if (added) data.vertices.push_back(p);
  return it->second;
}

// ASCII STL as a word stream: solid ... (facet normal n n n outer loop (vertex x y z){3}
// endloop endfacet)* endsolid, possibly several solids.
MeshData ParseAsciiStl(std::string_view text, std::string_view name) {
  std::vector<Token> tokens;
  ForEachLine(text, false, [&](const std::vector<std::string_view>& words, int line) {
    // the name after "solid" is free text: skip the rest of that line
    if (!words.empty() && words[0] == "solid") {
      tokens.push_back({words[0], line});
      return;
    }
    for (std::string_view word : words) tokens.push_back({word, line});
  });
  const int last_line = tokens.empty() ? 1 : tokens.back().line;
  size_t next = 0;
  // the next word, which should be what wanted describes
  auto take = [&](std::string_view wanted) -> const Token& {
    if (next == tokens.size()) {
      throw MeshFileError(Format("{}:{}: the file ends where {} was expected", name, last_line, wanted));
    }
    return tokens[next++];
  };
  // the next word, which must be keyword
  auto expect = [&](std::string_view keyword) {
    const Token& token = take(Format("'{}'", keyword));
    if (token.text != keyword) {
      throw MeshFileError(Format("{}:{}: expected '{}', found '{}'", name, token.line, keyword, token.text));
    }
  };
  auto take_number = [&] {
    const Token& token = take("a number");
    return ParseCoordinate(token.text, name, token.line);
  };
  MeshData data;
  std::map<std::array<double, 3>, int> index_of;
  while (next < tokens.size()) {
    expect("solid");
    // facets until endsolid (and its optional name on the same line)
    while (true) {
      const Token& word = take("'facet' or 'endsolid'");
      if (word.text == "endsolid") {
        while (next < tokens.size() && tokens[next].line == word.line) ++next;
        break;
      }
      if (word.text != "facet") {
        throw MeshFileError(
            Format("{}:{}: expected 'facet' or 'endsolid', found '{}'", name, word.line, word.text));
      }
      expect("normal");
      for (int i = 0; i < 3; ++i) take_number();
      expect("outer");
      expect("loop");
      std::array<int, 3> triangle;
      for (int corner = 0; corner < 3; ++corner) {
        expect("vertex");
        Vector3 p;
        for (int i = 0; i < 3; ++i) p[i] = take_number();
        triangle[corner] = InternVertex(p, index_of, data);
      }
      expect("endloop");
      expect("endfacet");
      data.triangles.push_back(triangle);
    }
  }
  return data;
}

uint32_t ReadUint32Le(std::string_view bytes, size_t offset) {
  uint32_t value = 0;
  for (int i = 3; i >= 0; --i) value = (value << 8) | static_cast<unsigned char>(bytes[offset + i]);
  return value;
}

// Binary STL: an 80-byte header, a uint32 count, then per triangle 12 little-endian
// float32 (normal, three vertices) and a uint16 attribute.
MeshData ParseBinaryStl(std::string_view bytes, std::string_view name) {
  const uint32_t count = ReadUint32Le(bytes, 80);
  MeshData data;
  std::map<std::array<double, 3>, int> index_of;
  data.triangles.reserve(count);
  for (uint32_t t = 0; t < count; ++t) {
    const size_t facet = 84 + 50 * static_cast<size_t>(t);
    std::array<int, 3> triangle;
    for (int corner = 0; corner < 3; ++corner) {
      Vector3 p;
      for (int i = 0; i < 3; ++i) {
        const size_t offset = facet + 12 + 12 * corner + 4 * i;
        p[i] = std::bit_cast<float>(ReadUint32Le(bytes, offset));
        if (!std::isfinite(p[i])) {
          throw MeshFileError(Format("{}: byte offset {} (triangle {}): vertex coordinate {} is not finite",
                                          name, offset, t, p[i]));
        }
      }
      triangle[corner] = InternVertex(p, index_of, data);
    }
    data.triangles.push_back(triangle);
  }
  return data;
}

bool StartsWithSolid(std::string_view bytes) {
  const size_t first = bytes.find_first_not_of(" \t\r\n");
  return first != std::string_view::npos && bytes.substr(first, 5) == "solid";
}

}  // namespace

MeshData ParseObj(std::string_view text, std::string_view name) {
  MeshData data;
  std::vector<std::array<ObjCorner, 3>> pending;  // triangles with positive indices unchecked
  ForEachLine(text, true, [&](const std::vector<std::string_view>& words, int line) {
    if (words.empty()) return;
    // v x y z [w] or v x y z r g b
    if (words[0] == "v") {
      const size_t n = words.size() - 1;
      if (n != 3 && n != 4 && n != 6) {
        throw MeshFileError(Format("{}:{}: vertex has {} numbers; it needs x y z (optionally w, or r g b)",
                                        name, line, n));
      }
      data.vertices.emplace_back(ParseCoordinate(words[1], name, line), ParseCoordinate(words[2], name, line),
                                 ParseCoordinate(words[3], name, line));
      for (size_t i = 4; i <= n; ++i) ParseCoordinate(words[i], name, line);
      return;
    }
    // f a b c ...: a polygon, fanned around its first corner
    if (words[0] == "f") {
      if (words.size() < 4) {
        throw MeshFileError(Format("{}:{}: face has {} corners; it needs at least 3", name, line,
                                        words.size() - 1));
      }
      std::vector<ObjCorner> corners;
      for (size_t i = 1; i < words.size(); ++i) {
        corners.push_back({ResolveObjIndex(words[i], data.vertices.size(), name, line), line});
      }
      for (size_t i = 1; i + 1 < corners.size(); ++i) {
        pending.push_back({corners[0], corners[i], corners[i + 1]});
      }
    }
  });
  // positive indices may name vertices defined later in the file: check them at the end
  for (const std::array<ObjCorner, 3>& corners : pending) {
    std::array<int, 3> triangle;
    for (int c = 0; c < 3; ++c) {
      if (corners[c].index >= static_cast<int64_t>(data.vertices.size())) {
        throw MeshFileError(Format("{}:{}: face index {} refers to vertex {}, but the file has {} vertices",
                                        name, corners[c].line, corners[c].index + 1, corners[c].index + 1,
                                        data.vertices.size()));
      }
      triangle[c] = static_cast<int>(corners[c].index);
    }
    data.triangles.push_back(triangle);
  }
  if (data.triangles.empty()) throw MeshFileError(Format("{}: has no faces (no 'f' statements)", name));
  return data;
}

MeshData ParseStl(std::string_view bytes, std::string_view name) {
  MeshData data;
  // binary when the size matches the header's count (a binary header may start with "solid")
  if (bytes.size() >= 84 && bytes.size() == 84 + 50 * static_cast<uint64_t>(ReadUint32Le(bytes, 80))) {
    data = ParseBinaryStl(bytes, name);
  } else if (StartsWithSolid(bytes)) {
    data = ParseAsciiStl(bytes, name);
  } else if (bytes.size() < 84) {
    throw MeshFileError(Format(
        "{}: not an STL file: {} bytes is too short for binary STL and it does not start with 'solid'", name,
        bytes.size()));
  } else {
    const uint64_t count = ReadUint32Le(bytes, 80);
    throw MeshFileError(Format(
        "{}: byte offset 80: binary STL header says {} triangles, which need {} bytes, but the file has {} "
        "(and it does not start with 'solid')",
        name, count, 84 + 50 * count, bytes.size()));
  }
  if (data.triangles.empty()) throw MeshFileError(Format("{}: has no triangles", name));
  return data;
}

MeshData ReadMeshFile(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension != ".obj" && extension != ".stl") {
    throw MeshFileError(Format("{}: unknown mesh file type '{}'; it must be .obj or .stl", name, extension));
  }
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    const bool exists = std::filesystem::exists(path, error);
    throw MeshFileError(Format("{}: {}", name, exists ? "is not a regular file" : "does not exist"));
  }
  std::ifstream file(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  if (file.bad() || !file.is_open()) throw MeshFileError(Format("{}: cannot be read", name));
  return extension == ".obj" ? ParseObj(bytes, name) : ParseStl(bytes, name);
}

}  // namespace hapticd::scene
