#include "ingest/modbus/modbus_decode.h"

#include <algorithm>
#include <bit>
#include <numeric>
#include <stdexcept>

namespace km::ingest::modbus {

int RegisterCount(RegisterType type) {
  switch (type) {
    case RegisterType::kInt16:
    case RegisterType::kUint16:
      return 1;
    case RegisterType::kInt32:
    case RegisterType::kUint32:
    case RegisterType::kFloat32:
      return 2;
  }
  return 1;
}

std::string_view ToString(RegisterType type) {
  switch (type) {
    case RegisterType::kInt16:
      return "int16";
    case RegisterType::kUint16:
      return "uint16";
    case RegisterType::kInt32:
      return "int32";
    case RegisterType::kUint32:
      return "uint32";
    case RegisterType::kFloat32:
      return "float32";
  }
  return "?";
}

std::string_view ToString(ByteOrder order) {
  return order == ByteOrder::kBig ? "big" : "little";
}
std::string_view ToString(WordOrder order) {
  return order == WordOrder::kBig ? "big" : "little";
}

bool ParseRegisterType(std::string_view name, RegisterType* type) {
  for (RegisterType t : {RegisterType::kInt16, RegisterType::kUint16, RegisterType::kInt32,
                         RegisterType::kUint32, RegisterType::kFloat32}) {
    if (name == ToString(t)) {
      *type = t;
      return true;
    }
  }
  return false;
}

bool ParseByteOrder(std::string_view name, ByteOrder* order) {
  if (name == "big")
    *order = ByteOrder::kBig;
  else if (name == "little")
    *order = ByteOrder::kLittle;
  else
    return false;
  return true;
}

bool ParseWordOrder(std::string_view name, WordOrder* order) {
  if (name == "big")
    *order = WordOrder::kBig;
  else if (name == "little")
    *order = WordOrder::kLittle;
  else
    return false;
  return true;
}

namespace {

std::uint16_t ValueWord(std::uint16_t word, ByteOrder byte_order) {
  if (byte_order == ByteOrder::kBig) return word;
  return static_cast<std::uint16_t>((word >> 8) | (word << 8));
}

}  // namespace

double DecodeRaw(std::span<const std::uint16_t> words, RegisterType type, ByteOrder byte_order,
                 WordOrder word_order) {
  if (words.size() != static_cast<std::size_t>(RegisterCount(type))) {
    throw std::invalid_argument("DecodeRaw: wrong number of registers for " +
                                std::string(ToString(type)));
  }
  if (RegisterCount(type) == 1) {
    const std::uint16_t v = ValueWord(words[0], byte_order);
    if (type == RegisterType::kInt16) return static_cast<double>(std::bit_cast<std::int16_t>(v));
    return static_cast<double>(v);
  }
  const std::uint16_t w0 = ValueWord(words[0], byte_order);
  const std::uint16_t w1 = ValueWord(words[1], byte_order);
  const std::uint16_t hi = word_order == WordOrder::kBig ? w0 : w1;
  const std::uint16_t lo = word_order == WordOrder::kBig ? w1 : w0;
  const std::uint32_t bits = (static_cast<std::uint32_t>(hi) << 16) | lo;
  switch (type) {
    case RegisterType::kInt32:
      return static_cast<double>(std::bit_cast<std::int32_t>(bits));
    case RegisterType::kUint32:
      return static_cast<double>(bits);
    default:
      return static_cast<double>(std::bit_cast<float>(bits));
  }
}

std::vector<ReadBlock> PlanBlocks(const std::vector<RegisterSpan>& spans, int max_registers) {
  if (max_registers < 2 || max_registers > kMaxRegistersPerRead) {
    throw std::invalid_argument("PlanBlocks: max_registers must be in 2..125");
  }
  std::vector<std::size_t> order(spans.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return spans[a].address < spans[b].address;
  });
  std::vector<ReadBlock> blocks;
  std::uint64_t previous_end = 0;  // one past the last register of the previous span
  for (std::size_t n = 0; n < order.size(); ++n) {
    const RegisterSpan& s = spans[order[n]];
    if (s.count < 1 || s.count > 2) throw std::invalid_argument("PlanBlocks: count must be 1 or 2");
    const std::uint64_t end = std::uint64_t{s.address} + static_cast<std::uint64_t>(s.count);
    if (end > 65536) throw std::invalid_argument("PlanBlocks: register beyond 65535");
    if (n > 0 && s.address < previous_end) {
      throw std::invalid_argument("PlanBlocks: overlapping registers at " +
                                  std::to_string(s.address));
    }
    previous_end = end;
    if (blocks.empty() || end - blocks.back().start > static_cast<std::uint64_t>(max_registers)) {
      blocks.push_back(ReadBlock{s.address, 0, {}, {}});
    }
    ReadBlock& b = blocks.back();
    b.count = static_cast<int>(end - b.start);
    b.members.push_back(order[n]);
    b.offsets.push_back(static_cast<int>(s.address - b.start));
  }
  return blocks;
}

}  // namespace km::ingest::modbus
