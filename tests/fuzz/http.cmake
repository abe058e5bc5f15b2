# The HTTP API (Api::handle), the server's request reading (Beast's parser with its limits), and
# the tile client's reading of the server's answers.
find_package(ZLIB REQUIRED)
find_package(Boost 1.74 REQUIRED)
add_library(pl_fuzz_api_env STATIC ${CMAKE_CURRENT_SOURCE_DIR}/api_env.cpp)
target_link_libraries(pl_fuzz_api_env PUBLIC pl_server pl_schema pl_common PRIVATE nlohmann_json::nlohmann_json ZLIB::ZLIB)
pl_target_warnings(pl_fuzz_api_env)
pl_add_fuzzer(api SOURCES fuzz_api.cpp LIBS pl_fuzz_api_env)
pl_add_fuzzer(http SOURCES fuzz_http.cpp LIBS pl_fuzz_api_env Boost::boost)
target_include_directories(fuzz_http PRIVATE ${CMAKE_SOURCE_DIR}/server/src)
target_sources(make_fuzz_seeds PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/seeds_http.cpp)
target_link_libraries(make_fuzz_seeds PRIVATE pl_fuzz_api_env)
pl_add_fuzzer(client_answers SOURCES fuzz_client_answers.cpp LIBS pl_client pl_schema pl_common Boost::boost)
target_include_directories(fuzz_client_answers PRIVATE ${CMAKE_SOURCE_DIR}/client/src ${CMAKE_SOURCE_DIR}/schema/src)
