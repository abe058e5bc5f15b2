# Assembles the files pl-server serves at /viewer/ into OUT: the viewer's own (SRC/src) and, from
# the npm install in NPM (npm_ci.sh), the parts of three.js it loads: the library, the Draco loader
# and map controls, the Draco decoder (WebAssembly) and their licences. Run by viewer/CMakeLists.txt:
#   cmake -DSRC=viewer -DNPM=BUILD/viewer-npm -DOUT=BUILD/viewer -P assemble.cmake
set(three ${NPM}/node_modules/three)
# vendor/ path <- file under node_modules/three
set(vendored
  "three/three.module.js|build/three.module.js"
  "three/three.core.js|build/three.core.js"
  "three/addons/loaders/DRACOLoader.js|examples/jsm/loaders/DRACOLoader.js"
  "three/addons/controls/OrbitControls.js|examples/jsm/controls/OrbitControls.js"
  "three/addons/controls/MapControls.js|examples/jsm/controls/MapControls.js"
  "three/LICENSE|LICENSE"
  "draco/draco_wasm_wrapper.js|examples/jsm/libs/draco/draco_wasm_wrapper.js"
  "draco/draco_decoder.wasm|examples/jsm/libs/draco/draco_decoder.wasm"
  "draco/README.md|examples/jsm/libs/draco/README.md")
foreach(pair IN LISTS vendored)
  string(REPLACE "|" ";" pair "${pair}")
  list(GET pair 1 from)
  if(NOT EXISTS ${three}/${from})
    message(FATAL_ERROR "viewer: ${three}/${from} is missing: the three.js package pinned by viewer/package-lock.json "
                        "no longer has it (update viewer/assemble.cmake to the package's layout), or npm ci did not finish "
                        "(remove ${NPM} and build again)")
  endif()
endforeach()
# Afresh each time: a file removed from the sources does not linger in the served folder.
file(REMOVE_RECURSE ${OUT})
file(COPY ${SRC}/src/ DESTINATION ${OUT})
foreach(pair IN LISTS vendored)
  string(REPLACE "|" ";" pair "${pair}")
  list(GET pair 0 to)
  list(GET pair 1 from)
  get_filename_component(dir ${OUT}/vendor/${to} DIRECTORY)
  file(COPY ${three}/${from} DESTINATION ${dir})
  get_filename_component(name ${from} NAME)
  get_filename_component(want ${to} NAME)
  if(NOT name STREQUAL want)
    file(RENAME ${dir}/${name} ${dir}/${want})
  endif()
endforeach()
file(TOUCH ${OUT}/.assembled)
