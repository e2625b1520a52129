// The register pattern served by km_modbus_test_server (and, re-encoded independently in
// Python, by pymodbus_server.py) and expected by the tests. Register words are built here by
// hand from the value's bytes — A B C D, most significant first — laid out on the wire as
// ABCD / CDAB / BADC / DCBA (docs/modbus.md), independently of ingest/modbus/modbus_decode.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <string>
#include <vector>

namespace km::test::modbus_pattern {

struct Entry {
  std::uint32_t address = 0;  // 0-based wire address
  std::string type;           // int16 uint16 int32 uint32 float32
  std::string byte_order;     // big / little
  std::string word_order;     // big / little
  double value = 0.0;         // the raw value (exactly representable in `type`)
  double scale = 1.0;
  double offset = 0.0;
};

// Dynamic registers of km_modbus_test_server (not in Entries()): a uint32 (ABCD) holding
// milliseconds since the server started, and a uint32 (ABCD) counting requests served.
inline constexpr std::uint32_t kMillisAddress = 100;
inline constexpr std::uint32_t kRequestsAddress = 102;
// The test server maps registers 0..kMappedRegisters-1 of both tables; reading beyond is
// answered with ILLEGAL DATA ADDRESS.
inline constexpr int kMappedRegisters = 200;

// The wire layout name of a byte/word order pair.
inline std::string Layout(const std::string& byte_order, const std::string& word_order,
                          int registers) {
  if (registers == 1) return byte_order == "big" ? "AB" : "BA";
  if (byte_order == "big") return word_order == "big" ? "ABCD" : "CDAB";
  return word_order == "big" ? "BADC" : "DCBA";
}

inline int Registers(const std::string& type) {
  return (type == "int16" || type == "uint16") ? 1 : 2;
}

// The register words (as libmodbus hands them over: (wire byte 0 << 8) | wire byte 1).
inline std::vector<std::uint16_t> WireWords(const Entry& e) {
  const int n = Registers(e.type);
  std::uint32_t bits = 0;
  if (e.type == "int16") bits = static_cast<std::uint16_t>(static_cast<std::int16_t>(e.value));
  if (e.type == "uint16") bits = static_cast<std::uint16_t>(e.value);
  if (e.type == "int32") bits = static_cast<std::uint32_t>(static_cast<std::int32_t>(e.value));
  if (e.type == "uint32") bits = static_cast<std::uint32_t>(e.value);
  if (e.type == "float32") bits = std::bit_cast<std::uint32_t>(static_cast<float>(e.value));
  // Value bytes, most significant first: A B (16-bit) or A B C D (32-bit).
  std::vector<std::uint8_t> v;
  for (int i = 2 * n - 1; i >= 0; --i) v.push_back(static_cast<std::uint8_t>(bits >> (8 * i)));
  const std::string layout = Layout(e.byte_order, e.word_order, n);
  std::vector<std::uint8_t> wire;
  for (char letter : layout) wire.push_back(v[static_cast<std::size_t>(letter - 'A')]);
  std::vector<std::uint16_t> words;
  for (int r = 0; r < n; ++r) {
    words.push_back(static_cast<std::uint16_t>((wire[2 * r] << 8) | wire[2 * r + 1]));
  }
  return words;
}

// Every type × byte order (× word order for 32-bit types), plus two scaled channels.
inline std::vector<Entry> Entries() {
  struct V {
    const char* type;
    double value;
  };
  const std::vector<V> v16 = {
      {"int16", -2.0}, {"int16", -12345.0}, {"uint16", 65534.0}, {"uint16", 51234.0}};
  const std::vector<V> v32 = {{"int32", -123456789.0},
                              {"uint32", 4000000000.0},
                              {"float32", -12.375},
                              {"float32", static_cast<double>(1234.5678f)}};
  std::vector<Entry> out;
  std::uint32_t a = 0;
  for (const V& x : v16) {
    for (const char* bo : {"big", "little"}) {
      out.push_back(Entry{a, x.type, bo, "big", x.value, 1.0, 0.0});
      a += 1;
    }
  }
  for (const V& x : v32) {
    for (const char* bo : {"big", "little"}) {
      for (const char* wo : {"big", "little"}) {
        out.push_back(Entry{a, x.type, bo, wo, x.value, 1.0, 0.0});
        a += 2;
      }
    }
  }
  out.push_back(Entry{a, "int16", "big", "big", -2.0, 0.5, 10.0});
  a += 1;
  out.push_back(Entry{a, "float32", "big", "big", -12.375, 2.0, -1.0});
  return out;
}

inline double Expected(const Entry& e) {
  return e.value * e.scale + e.offset;
}

}  // namespace km::test::modbus_pattern
