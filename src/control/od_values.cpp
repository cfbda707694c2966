#include "control/od_values.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#include "control/names.hpp"

namespace cansim::control {

namespace {

// The value range of an integer type of `bytes` bytes.
struct Range {
  long double lo, hi;
};
Range range_of(DataType t) {
  const int bits = int(type_size(t)) * 8;
  if (is_signed(t)) return {-std::ldexp(1.0L, bits - 1), std::ldexp(1.0L, bits - 1) - 1};
  return {0, std::ldexp(1.0L, bits) - 1};
}

// A number read from the message, wide enough for every D-Bus integer.
struct Number {
  bool is_unsigned = false;
  bool is_double = false;
  std::int64_t i = 0;
  std::uint64_t u = 0;
  double d = 0;
  long double as_long_double() const { return is_double ? d : is_unsigned ? (long double)u : (long double)i; }
};

// One D-Bus basic value of C++ type T into `n`.
template <typename T>
int read_as(sd_bus_message* m, char type, Number& n) {
  T v{};
  const int r = sd_bus_message_read_basic(m, type, &v);
  if constexpr (std::is_same_v<T, double>) n.is_double = true, n.d = v;
  else if constexpr (std::is_unsigned_v<T>) n.is_unsigned = true, n.u = v;
  else n.i = v;
  return r;
}

int read_number(sd_bus_message* m, char type, Number& n) {
  switch (type) {
    case 'y': return read_as<std::uint8_t>(m, type, n);
    case 'q': return read_as<std::uint16_t>(m, type, n);
    case 'u': return read_as<std::uint32_t>(m, type, n);
    case 't': return read_as<std::uint64_t>(m, type, n);
    case 'n': return read_as<std::int16_t>(m, type, n);
    case 'i': return read_as<std::int32_t>(m, type, n);
    case 'x': return read_as<std::int64_t>(m, type, n);
    case 'd': return read_as<double>(m, type, n);
    case 'b': {  // a D-Bus boolean is an int that sd-bus gives as 0 or 1
      const int r = read_as<int>(m, type, n);
      n.i = n.i ? 1 : 0;
      return r;
    }
    default: return -EINVAL;
  }
}

// "123", "-5", "0x1F", "1.5": a number given as text.
bool parse_number_text(const std::string& s, Number& n) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  if (s[0] == '-') {
    long long v = std::strtoll(s.c_str(), &end, 0);
    if (errno == 0 && end && *end == 0) {
      n.i = v;
      return true;
    }
  } else {
    unsigned long long v = std::strtoull(s.c_str(), &end, 0);
    if (errno == 0 && end && *end == 0) {
      n.is_unsigned = true;
      n.u = v;
      return true;
    }
  }
  errno = 0;
  double d = std::strtod(s.c_str(), &end);
  if (errno != 0 || !end || *end != 0 || !std::isfinite(d)) return false;
  n.is_double = true;
  n.d = d;
  return true;
}

bool encode_number(const OdEntry& e, const Number& n, std::vector<std::uint8_t>& out, std::string& error_name,
                   std::string& message) {
  out.assign(type_size(e.type), 0);
  if (is_real(e.type)) {
    encode_f(e.type, double(n.as_long_double()), out.data());
    return true;
  }
  if (n.is_double && (!std::isfinite(n.d) || std::trunc(n.d) != n.d)) {
    error_name = kErrorInvalidArgument;
    message = std::string("expected an integer for ") + type_name(e.type);
    return false;
  }
  Range r = e.type == DataType::kBoolean ? Range{0, 1} : range_of(e.type);
  long double v = n.as_long_double();
  if (v < r.lo || v > r.hi) {
    error_name = kErrorOutOfRange;
    message = "value out of the range of " + std::string(type_name(e.type));
    return false;
  }
  if (is_signed(e.type))
    encode_i(e.type, n.is_double ? std::int64_t(n.d) : n.is_unsigned ? std::int64_t(n.u) : n.i, out.data());
  else encode_u(e.type, n.is_double ? std::uint64_t(n.d) : n.is_unsigned ? n.u : std::uint64_t(n.i), out.data());
  return true;
}

}  // namespace

const char* dbus_signature(DataType t) {
  switch (t) {
    case DataType::kBoolean: return "b";
    case DataType::kUnsigned8: return "y";
    case DataType::kInteger8:
    case DataType::kInteger16: return "n";
    case DataType::kUnsigned16: return "q";
    case DataType::kInteger24:
    case DataType::kInteger32: return "i";
    case DataType::kUnsigned24:
    case DataType::kUnsigned32: return "u";
    case DataType::kReal32:
    case DataType::kReal64: return "d";
    case DataType::kVisibleString:
    case DataType::kUnicodeString: return "s";
    case DataType::kOctetString:
    case DataType::kDomain: return "ay";
    default: return is_signed(t) ? "x" : "t";
  }
}

int append_value(sd_bus_message* m, const OdEntry& e, std::span<const std::uint8_t> bytes) {
  const char* sig = dbus_signature(e.type);
  int r = sd_bus_message_open_container(m, 'v', sig);
  if (r < 0) return r;
  if (sig[0] == 'a') {
    r = sd_bus_message_append_array(m, 'y', bytes.data(), bytes.size());
  } else if (sig[0] == 's') {
    std::string s(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    s = s.substr(0, std::strlen(s.c_str()));  // stop at an embedded NUL
    r = sd_bus_message_append_basic(m, 's', s.c_str());
  } else {
    std::uint8_t buf[8] = {};
    std::memcpy(buf, bytes.data(), std::min<std::size_t>(bytes.size(), 8));
    switch (sig[0]) {
      case 'b': {
        int v = decode_u(e.type, buf) != 0;
        r = sd_bus_message_append_basic(m, 'b', &v);
        break;
      }
      case 'y': {
        std::uint8_t v = std::uint8_t(decode_u(e.type, buf));
        r = sd_bus_message_append_basic(m, 'y', &v);
        break;
      }
      case 'n': {
        std::int16_t v = std::int16_t(decode_i(e.type, buf));
        r = sd_bus_message_append_basic(m, 'n', &v);
        break;
      }
      case 'q': {
        std::uint16_t v = std::uint16_t(decode_u(e.type, buf));
        r = sd_bus_message_append_basic(m, 'q', &v);
        break;
      }
      case 'i': {
        std::int32_t v = std::int32_t(decode_i(e.type, buf));
        r = sd_bus_message_append_basic(m, 'i', &v);
        break;
      }
      case 'u': {
        std::uint32_t v = std::uint32_t(decode_u(e.type, buf));
        r = sd_bus_message_append_basic(m, 'u', &v);
        break;
      }
      case 'x': {
        std::int64_t v = decode_i(e.type, buf);
        r = sd_bus_message_append_basic(m, 'x', &v);
        break;
      }
      case 't': {
        std::uint64_t v = decode_u(e.type, buf);
        r = sd_bus_message_append_basic(m, 't', &v);
        break;
      }
      case 'd': {
        double v = decode_f(e.type, buf);
        r = sd_bus_message_append_basic(m, 'd', &v);
        break;
      }
    }
  }
  if (r < 0) return r;
  return sd_bus_message_close_container(m);
}

bool read_value(sd_bus_message* m, const OdEntry& e, std::vector<std::uint8_t>& out, std::string& error_name,
                std::string& message) {
  char type = 0;
  const char* contents = nullptr;
  if (sd_bus_message_peek_type(m, &type, &contents) <= 0 || type != 'v' || !contents) {
    error_name = kErrorInvalidArgument;
    message = "expected a variant value";
    return false;
  }
  if (sd_bus_message_enter_container(m, 'v', contents) < 0) {
    error_name = kErrorInvalidArgument;
    message = "malformed variant";
    return false;
  }
  const std::string sig = contents;
  bool ok = false;
  auto bad = [&](const std::string& expected) {
    error_name = kErrorInvalidArgument;
    message = "expected " + expected + " for an object of type " + type_name(e.type) + ", got a '" + sig + "'";
    return false;
  };
  if (sig == "ay") {
    const void* p = nullptr;
    std::size_t n = 0;
    if (sd_bus_message_read_array(m, 'y', &p, &n) < 0) return bad("bytes");
    const auto* b = static_cast<const std::uint8_t*>(p);
    out.assign(b, b + n);
    ok = is_variable_size(e.type) || n == type_size(e.type) ||
         bad("exactly " + std::to_string(type_size(e.type)) + " bytes");
  } else if (sig == "s") {
    const char* s = nullptr;
    if (sd_bus_message_read_basic(m, 's', &s) < 0) return bad("a string");
    if (is_variable_size(e.type)) {
      out.assign(s, s + std::strlen(s));
      ok = true;
    } else {
      Number n;
      ok = parse_number_text(s, n) ? encode_number(e, n, out, error_name, message) : bad("a number");
    }
  } else if (sig.size() == 1 && std::strchr("yqutnixbd", sig[0])) {
    Number n;
    if (read_number(m, sig[0], n) < 0) return bad("a number");
    ok = !is_variable_size(e.type) ? encode_number(e, n, out, error_name, message) : bad("a string or bytes");
  } else {
    return bad("a number, a string or bytes");
  }
  sd_bus_message_exit_container(m);
  return ok;
}

}  // namespace cansim::control
