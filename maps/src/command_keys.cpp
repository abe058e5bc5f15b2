// pl-map's commands for who may use a map store and who signs its versions: the bearer tokens
// (token-add, token-list, token-revoke) and the fleet's signing key (key-gen).
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"

namespace pl::maps {

// Tokens: made here (random), stored hashed, revoked without restarting any server.
void add_token_commands(cli::Tool& tool, std::ostream& out) {
  struct State {
    std::string db, role = "read", note;
    std::int64_t id = 0;
  };
  auto s = std::make_shared<State>();
  CLI::App& add = tool.command("token-add", "make a new bearer token and register it (the store keeps only its SHA-256)", [s, &out] {
    auto store = pl::store::Store::open(s->db, false);
    const auto role = pl::store::parse_role(s->role);
    if (!role) throw pl::Error("--role " + s->role + ": expected read, report, upload or admin");
    const std::string token = pl::store::random_token();
    const auto id = store.add_token(token, *role, s->note);
    out << token << '\n';
    std::fprintf(stderr, "token %lld (%s) registered: keep it now, the store holds only its hash; revoke it with pl-map token-revoke --id %lld\n",
                 static_cast<long long>(id), s->role.c_str(), static_cast<long long>(id));
    return 0;
  });
  db_option(add, s->db, false);
  add.add_option("--role", s->role, "read, report (a vehicle's: reads maps, sends change reports), upload or admin (each "
                 "includes the ones before it)")->check(CLI::IsMember({"read", "report", "upload", "admin"}));
  add.add_option("--note", s->note, "what or who the token is for");
  CLI::App& list = tool.command("token-list", "the tokens: id, role, created, revoked, note (never a token)", [s, &out] {
    auto store = pl::store::Store::open(s->db, false);
    out << format_text("%-6s %-7s %-25s %-25s %s\n", "id", "role", "created", "revoked", "note");
    for (const auto& t : store.list_tokens())
      out << format_text("%-6lld %-7s %-25s %-25s %s\n", static_cast<long long>(t.id), pl::store::role_name(t.role), t.created.c_str(),
            t.revoked ? t.revoked->c_str() : "-", pl::printable(t.note).c_str());
    return 0;
  });
  db_option(list, s->db, false);
  CLI::App& revoke = tool.command("token-revoke", "take a token out of force, at once for every server on the store", [s, &out] {
    auto store = pl::store::Store::open(s->db, false);
    if (!store.revoke_token(s->id))
      throw pl::Error("token " + std::to_string(s->id) + ": no such token, or revoked already (pl-map token-list --db " + pl::store::display_name(s->db) + ")");
    out << format_text("token %lld revoked\n", static_cast<long long>(s->id));
    return 0;
  });
  db_option(revoke, s->db, false);
  cli::number(revoke, "--id", s->id, "the token's id (pl-map token-list)", cli::at_least(1))->required()->default_str("");
}

// The fleet's signing key: the private half signs versions as they are published (pl-map publish
// and push --signing-key), the public half goes to every vehicle (pl-localize --fleet-key) and to
// the servers that take uploads (pl-server --fleet-key).
void add_key_gen(cli::Tool& tool, std::ostream& out) {
  auto prefix = std::make_shared<std::string>();
  CLI::App& c = tool.command("key-gen", "make an Ed25519 key pair for signing map versions: PREFIX.key (private, mode 0600) and PREFIX.pub", [prefix, &out] {
    const auto key = pl::signing::SigningKey::generate();
    const std::string priv = *prefix + ".key", pub = *prefix + ".pub";
    if (pl::file_exists(priv) || pl::file_exists(pub))
      throw pl::Error(priv + " or " + pub + " exists already: a key is never written over (move the old pair away, or pick another --out)");
    key.save(priv);
    pl::signing::save_public_key(key.public_key(), pub);
    out << format_text("key %s: private key %s (keep it where versions are published; never on a vehicle), public key %s "
          "(pl-localize --fleet-key, pl-server --fleet-key)\n",
          pl::signing::key_id(key.public_key()).c_str(), priv.c_str(), pub.c_str());
    return 0;
  });
  c.add_option("--out", *prefix, "the files' path without .key/.pub, e.g. /etc/pointlocalization/fleet")->required()->type_name("PREFIX");
}

}  // namespace pl::maps
