#pragma once
// Building PX4 ULog files byte by byte in tests: a byte buffer, the 16-byte header and messages
// [uint16 size][uint8 type][payload] (format: PX4 user guide, "ULog File Format").

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace dronetwin::test {

class Bytes {
 public:
  // Byte by byte with push_back: GCC 12 warns falsely (-Wstringop-overflow) about the range
  // inserts of small vectors once they are inlined.
  template <class T>
  Bytes& put(T v) {
    std::uint8_t raw[sizeof(T)];
    std::memcpy(raw, &v, sizeof(T));
    for (const std::uint8_t c : raw) b_.push_back(c);
    return *this;
  }
  Bytes& text(const std::string& s) {
    for (const char c : s) b_.push_back(static_cast<std::uint8_t>(c));
    return *this;
  }
  Bytes& append(const Bytes& other) {
    b_.reserve(b_.size() + other.b_.size());
    for (const std::uint8_t c : other.b_) b_.push_back(c);
    return *this;
  }
  const std::vector<std::uint8_t>& bytes() const { return b_; }
  std::size_t size() const { return b_.size(); }

 private:
  std::vector<std::uint8_t> b_;
};

/// Appends one message [uint16 size][uint8 type][payload].
inline void message(Bytes& f, char type, const Bytes& payload) {
  f.put(static_cast<std::uint16_t>(payload.size())).put(type).append(payload);
}

/// An 'I'/'P' payload (or 'M'/'Q' with a leading `prefix` byte): [key_len][key][value].
inline Bytes key_value(const std::string& key, const Bytes& value, int prefix = -1) {
  Bytes p;
  if (prefix >= 0) p.put(static_cast<std::uint8_t>(prefix));
  p.put(static_cast<std::uint8_t>(key.size())).text(key);
  p.append(value);
  return p;
}

/// The 16-byte file header: magic, version 1, start timestamp.
inline Bytes ulog_header(std::uint64_t start_us = 1000) {
  Bytes f;
  f.text("ULog").put(std::uint8_t{0x01}).put(std::uint8_t{0x12}).put(std::uint8_t{0x35});
  f.put(std::uint8_t{1}).put(start_us);
  return f;
}

/// A format 'F' message "name:fields".
inline void format(Bytes& f, const std::string& definition) {
  message(f, 'F', Bytes().text(definition));
}

/// A subscription 'A' message.
inline void subscribe(Bytes& f, const std::string& name, std::uint16_t msg_id,
                      std::uint8_t multi_id = 0) {
  message(f, 'A', Bytes().put(multi_id).put(msg_id).text(name));
}

}  // namespace dronetwin::test
