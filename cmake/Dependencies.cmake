# Every dependency is a Debian package; scripts/install-deps.sh installs them.
find_package(PkgConfig REQUIRED)
pkg_check_modules(SYSTEMC REQUIRED IMPORTED_TARGET systemc)
find_package(embree 3 REQUIRED)
find_package(glm REQUIRED)
find_package(TBB REQUIRED)
find_package(assimp REQUIRED)
find_package(SQLite3 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(tomlplusplus REQUIRED)
# libzip: pkg-config, because its CMake config insists on the zipcmp tools being installed.
pkg_check_modules(LIBZIP REQUIRED IMPORTED_TARGET libzip)
find_package(Threads REQUIRED)
find_package(ZLIB REQUIRED)
find_package(pugixml REQUIRED)
pkg_check_modules(STB REQUIRED IMPORTED_TARGET stb)
if(RTSIM_BUILD_TESTS)
  find_package(GTest REQUIRED)
  include(GoogleTest)
endif()
if(RTSIM_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()

# GLM: keep the default (radians, no experimental extensions) but allow gtx helpers.
add_compile_definitions(GLM_FORCE_CXX17 GLM_ENABLE_EXPERIMENTAL)

# The git revision goes into every result file so that runs are self-describing:
# cmake/revision.cmake writes it at every build (cli/CMakeLists.txt), marked dirty
# when the working tree has uncommitted changes.
