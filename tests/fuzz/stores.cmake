# The SQLite files the product opens: the map store (as pl-server and pl-map open it) and the
# vehicle's disk cache. Dictionaries: store.dict, tile_cache.dict.
find_package(SQLite3 REQUIRED)
pl_add_fuzzer(store SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/fuzz_store.cpp LIBS pl_schema pl_common SQLite::SQLite3)
pl_add_fuzzer(tile_cache SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/fuzz_tile_cache.cpp LIBS pl_client pl_schema pl_common SQLite::SQLite3)
target_sources(make_fuzz_seeds PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/seeds_stores.cpp)
target_link_libraries(make_fuzz_seeds PRIVATE pl_schema pl_client SQLite::SQLite3)
