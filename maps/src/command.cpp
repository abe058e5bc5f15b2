// pl-map's tool: its commands in the order --help lists them (each group in its own file,
// command.hpp), and what the groups share: the --db option.
#include "pl/maps/command.hpp"

#include <iostream>

#include "command.hpp"
#include "pl/common/output_path.hpp"
#include "pl/common/text.hpp"
#include "pl/schema/store.hpp"

namespace pl::maps {

CLI::Option* db_option(CLI::App& c, std::string& db, bool create) {
  auto check = [create](std::string& path) -> std::string {
    if (pl::store::is_postgres_url(path) || pl::file_exists(path)) return "";
    return create ? pl::output_file_problem(path) : path + ": no such map store (create one with pl-map tile)";
  };
  return c.add_option("--db", db,
                      create ? "the map store: a SQLite file (created when missing) or a postgresql://USER@HOST/DB URL"
                             : "the map store: a SQLite file or a postgresql://USER@HOST/DB URL")
      ->required()->type_name("FILE|URL")->check(CLI::Validator(check, ""));
}

void add_commands(cli::Tool& tool, std::ostream& out) {
  add_build(tool, out);
  add_tile(tool, out);
  add_store_commands(tool, out);
  add_token_commands(tool, out);
  add_push(tool, out);
  add_key_gen(tool, out);
  add_migrate(tool, out);
  add_check(tool, out);
  add_changes(tool, out);
  add_update(tool, out);
}

int map_main(int argc, char** argv, std::ostream& out) {
  cli::Tool tool("pl-map", "Build maps from drives, cut them into Draco tiles in a versioned SQLite map store, publish them.");
  add_commands(tool, out);
  return tool.main(argc, argv);
}

int map_main(int argc, char** argv) { return map_main(argc, argv, std::cout); }

}  // namespace pl::maps
