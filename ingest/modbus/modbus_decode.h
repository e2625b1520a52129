// Pure Modbus register decoding and block planning (no libmodbus, no sockets).
//
// A Modbus register is 16 bits; on the wire it is two bytes, high byte first. libmodbus hands
// each register over as a host-order uint16 with the two wire bytes already combined:
// word = (wire_byte0 << 8) | wire_byte1. Devices disagree on how they lay values out:
//
//   byte_order  — order of the two bytes inside each register: big = as on the wire (AB),
//                 little = swapped (BA).
//   word_order  — for 32-bit values, which register holds the high half: big = the first
//                 (lower address) register, little = the second.
//
// With the value's big-endian bytes A B C D (A most significant), the four 32-bit layouts on
// the wire are (byte_order/word_order): ABCD = big/big, CDAB = big/little, BADC = little/big,
// DCBA = little/little. 16-bit types use byte_order only. float32 is IEEE 754 binary32.
// The engineering value is value_um = raw · scale + offset.
//
// Block planning groups the registers of a device into contiguous reads of at most 125
// registers (the Modbus limit of FC3/FC4), greedily in address order: a block grows while the
// span from its first register to the end of the next value fits. Unused registers inside a
// block are read and ignored. Values of one block are read in one request and so are coherent
// (one timestamp); values of different blocks are not.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace km::ingest::modbus {

enum class RegisterType { kInt16, kUint16, kInt32, kUint32, kFloat32 };
enum class ByteOrder { kBig, kLittle };
enum class WordOrder { kBig, kLittle };

inline constexpr int kMaxRegistersPerRead = 125;  // Modbus FC3/FC4 limit

// Number of 16-bit registers a value of `type` occupies (1 or 2).
int RegisterCount(RegisterType type);

// Names used in configuration files: "int16", "uint16", "int32", "uint32", "float32";
// "big", "little". The parsers return false on an unknown name.
std::string_view ToString(RegisterType type);
std::string_view ToString(ByteOrder order);
std::string_view ToString(WordOrder order);
bool ParseRegisterType(std::string_view name, RegisterType* type);
bool ParseByteOrder(std::string_view name, ByteOrder* order);
bool ParseWordOrder(std::string_view name, WordOrder* order);

// Decodes one value from `words` (size must be RegisterCount(type); throws
// std::invalid_argument otherwise). Returns the raw value (before scale/offset) as a double;
// every supported type is exactly representable.
double DecodeRaw(std::span<const std::uint16_t> words, RegisterType type, ByteOrder byte_order,
                 WordOrder word_order);

// raw · scale + offset.
inline double ApplyScale(double raw, double scale, double offset) {
  return raw * scale + offset;
}

// One value to read: its first register (0-based wire address) and its register count.
struct RegisterSpan {
  std::uint32_t address = 0;
  int count = 1;
};

// One contiguous read. `members` are indices into the span list given to PlanBlocks, in
// address order; `offsets[i]` is the position of members[i]'s first register in the block.
struct ReadBlock {
  std::uint32_t start = 0;
  int count = 0;
  std::vector<std::size_t> members;
  std::vector<int> offsets;
};

// Greedy grouping of `spans` into blocks of at most `max_registers` registers (see above).
// Spans must not overlap and must lie within 0..65535 (throws std::invalid_argument).
std::vector<ReadBlock> PlanBlocks(const std::vector<RegisterSpan>& spans,
                                  int max_registers = kMaxRegistersPerRead);

}  // namespace km::ingest::modbus
