// The parts of a request and an answer the API handlers share: see api_parts.hpp.
#include "api_parts.hpp"

#include <zlib.h>

#include <cctype>
#include <climits>
#include <cstdio>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl::server::api_parts {

// Messages echo what the client sent (targets, names, JSON parser errors): made valid UTF-8 here.
[[noreturn]] void fail(int status, const std::string& message) { throw HttpError{status, valid_utf8(message), {}}; }

ApiResponse json_response(int status, const json& j, const std::string& route) {
  ApiResponse r;
  r.status = status;
  // `replace`: a string that is not valid UTF-8 (a name read back from a damaged store, say) is
  // written with U+FFFD instead of making dump() throw.
  r.body = j.dump(-1, ' ', false, json::error_handler_t::replace) + "\n";
  r.route = route;
  return r;
}

ApiResponse revalidated(ApiResponse r) {
  r.revalidate = true;
  return r;
}

// Deterministic across processes and builds (std::hash is not): every replica behind one cache
// must give one answer the same tag.
std::string answer_tag(const store::MapInfo& map, std::int64_t version, std::string_view target) {
  const std::string text = std::to_string(map.id) + '\n' + map.created + '\n' + std::to_string(version) + '\n' + std::string(target);
  std::uint64_t a = 0xcbf29ce484222325ull, b = 0x84222325cbf29ce4ull;  // two FNV-1a 64 with different bases
  for (unsigned char c : text) {
    a = (a ^ c) * 0x100000001b3ull;
    b = (b ^ c ^ 0x5a) * 0x100000001b3ull;
  }
  char out[33];
  std::snprintf(out, sizeof out, "%016llx%016llx", static_cast<unsigned long long>(a), static_cast<unsigned long long>(b));
  return out;
}


[[noreturn]] void method_not_allowed(const std::string& method, const std::string& route, const char* allow) {
  throw HttpError{405, valid_utf8(method + " is not allowed on " + route + " (allowed: " + allow + ")"), {{"Allow", allow}}};
}

// Does an Accept-Encoding header accept gzip? Codings are comma-separated, each with an optional
// q-value (RFC 9110 12.5.3): "gzip", "gzip;q=0.5" and "*" accept it, "gzip;q=0" refuses it.
bool accepts_gzip(std::string_view header) {
  bool star = false, gzip = false, gzip_named = false;
  for (auto item : split_fields(header, ",")) {
    auto semi = item.find(';');
    std::string_view name = item.substr(0, semi);
    while (!name.empty() && (name.front() == ' ' || name.front() == '\t')) name.remove_prefix(1);
    while (!name.empty() && (name.back() == ' ' || name.back() == '\t')) name.remove_suffix(1);
    double q = 1.0;
    if (semi != std::string_view::npos) {
      std::string params(item.substr(semi + 1));
      for (auto& c : params) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      auto at = params.find("q=");
      double v = 0;
      if (at != std::string::npos) {
        std::string_view qs = std::string_view(params).substr(at + 2);
        qs = qs.substr(0, qs.find_first_of(" ;\t"));
        q = parse_double(qs, v) ? v : 0.0;
      }
    }
    std::string lower(name);
    for (auto& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (lower == "gzip" || lower == "x-gzip") gzip_named = true, gzip = gzip || q > 0;
    if (lower == "*") star = q > 0;
  }
  return gzip_named ? gzip : star;
}

// gzip (RFC 1952) of the bytes, at zlib's fastest level: JSON answers shrink 2-4x at a few
// microseconds a kilobyte.
std::string url_decode(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out += static_cast<char>(std::stoi(std::string(s.substr(i + 1, 2)), nullptr, 16));
      i += 2;
    } else if (s[i] == '+') {
      out += ' ';
    } else {
      out += s[i];
    }
  }
  return out;
}


Target parse_target(const std::string& target) {
  Target t;
  auto q = target.find('?');
  std::string path = target.substr(0, q);
  for (auto seg : split_fields(path, "/")) t.segments.push_back(url_decode(seg));
  if (q != std::string::npos) {
    std::string qs = target.substr(q + 1);
    for (auto kv : split_fields(qs, "&")) {
      auto eq = kv.find('=');
      std::string k = url_decode(kv.substr(0, eq)), v = eq == std::string_view::npos ? "" : url_decode(kv.substr(eq + 1));
      t.query[k] = v;
    }
  }
  return t;
}

double query_number(const Target& t, const std::string& key, bool required, double fallback) {
  auto it = t.query.find(key);
  if (it == t.query.end()) {
    if (required) fail(400, "missing query parameter " + key);
    return fallback;
  }
  double v;
  if (!parse_double(it->second, v)) fail(400, "query parameter " + key + " must be a number, got \"" + it->second + "\"");
  return v;
}

std::int64_t parse_version(const std::string& s) {
  long long v = 0;
  if (!parse_int(s, v) || v < 1) fail(400, "version must be a positive whole number, got \"" + s + "\"");
  return v;
}

std::int32_t parse_tile_index(const std::string& s) {
  long long v = 0;
  if (!parse_int(s, v) || v < INT32_MIN || v > INT32_MAX) fail(400, "tile index must be a whole number, got \"" + s + "\"");
  return static_cast<std::int32_t>(v);
}

std::string tile_url(const std::string& map, std::int64_t v, const TileKey& k) {
  return "/v1/maps/" + map + "/versions/" + std::to_string(v) + "/tiles/" + std::to_string(k.tx) + "/" + std::to_string(k.ty);
}

}  // namespace pl::server::api_parts
