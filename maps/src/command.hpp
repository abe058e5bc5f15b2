// The pl-map commands by group, one file each, and what the groups share (command.cpp):
//   command_build.cpp    build, tile: a map from a drive, a cloud into a staged version's tiles
//   command_store.cpp    publish, rollback, list, info, diff, push, migrate, check: the store
//   command_keys.cpp     token-add, token-list, token-revoke, key-gen: who may use it, who signs
//   command_changes.cpp  changes, update: the fleet's change reports, and the versions made from them
// Each add_* adds its commands to the tool; what they print goes to `out`.
#pragma once

#include <ostream>
#include <string>

#include "pl/common/cli.hpp"

namespace pl::maps {

// --db FILE of an existing store, or (`create`) of one that may be created.
CLI::Option* db_option(CLI::App& c, std::string& db, bool create);

void add_build(cli::Tool& tool, std::ostream& out);
void add_tile(cli::Tool& tool, std::ostream& out);

void add_store_commands(cli::Tool& tool, std::ostream& out);  // publish, rollback, list, info, diff
void add_push(cli::Tool& tool, std::ostream& out);
void add_migrate(cli::Tool& tool, std::ostream& out);
void add_check(cli::Tool& tool, std::ostream& out);

void add_token_commands(cli::Tool& tool, std::ostream& out);  // token-add, token-list, token-revoke
void add_key_gen(cli::Tool& tool, std::ostream& out);

void add_changes(cli::Tool& tool, std::ostream& out);
void add_update(cli::Tool& tool, std::ostream& out);

}  // namespace pl::maps
