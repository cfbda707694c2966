#include "ctl/json.hpp"

#include <charconv>
#include <cmath>
#include <cstdlib>

namespace cansim::ctl {

Json json_number(double d) {
  if (!std::isfinite(d)) return nullptr;
  const auto f = static_cast<float>(d);
  if (static_cast<double>(f) != d) return d;
  char buf[32];
  auto end = std::to_chars(buf, buf + sizeof buf - 1, f).ptr;
  *end = '\0';
  return std::strtod(buf, nullptr);  // the double nearest the float's text: dumped as that text
}

Json json_value(const Value& v) {
  return std::visit(
      [](const auto& x) -> Json {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, Bytes>) {
          std::string hex = format_bytes(x);
          std::erase(hex, ' ');
          return hex;
        } else if constexpr (std::is_same_v<T, double>) {
          return json_number(x);
        } else {
          return x;
        }
      },
      v);
}

Json json_text_or_null(const std::string& text) { return text.empty() ? Json(nullptr) : Json(text); }

Json json_seconds(std::int64_t us) { return us < 0 ? Json(nullptr) : Json(double(us) / 1e6); }

void print_json(std::ostream& out, const Json& document) {
  out << document.dump(-1, ' ', false, Json::error_handler_t::replace) << '\n';
}

}  // namespace cansim::ctl
