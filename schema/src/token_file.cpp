// Tokens from a file of "ROLE TOKEN" lines (pl-server --tokens) into the store's tokens.
#include <string>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/schema/store.hpp"

namespace pl::store {

std::size_t add_token_file(Store& store, const std::string& path, const std::function<void(std::size_t line)>& revoked) {
  LineReader reader(path);
  std::string line;
  std::size_t n = 0;
  while (reader.next(line)) {
    auto f = split_fields(line, " \t\r");
    auto role = f.size() == 2 ? parse_role(f[0]) : std::nullopt;
    if (!role) reader.fail("\"ROLE TOKEN\" with ROLE read, report, upload or admin", line);
    const std::string token(f[1]);
    if (!store.check_token(token)) {
      try {
        store.add_token(token, *role, "from " + path);
      } catch (const Error& e) {
        // Registered already and not in force: revoked. The file does not bring it back.
        if (std::string(e.what()).find("already registered") == std::string::npos) throw;
        revoked(reader.line_number());
        continue;
      }
    }
    ++n;
  }
  return n;
}

}  // namespace pl::store
