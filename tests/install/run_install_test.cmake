# cmake -P script behind the Install.PackageConsumerAndProgram test (tests/install/CMakeLists.txt passes the -D values).
cmake_minimum_required(VERSION 3.20)
foreach(v BINARY_DIR PREFIX CONSUMER_SOURCE_DIR CONSUMER_BINARY_DIR GENERATOR CXX_COMPILER)
  if(NOT DEFINED ${v} OR "${${v}}" STREQUAL "")
    message(FATAL_ERROR "run_install_test.cmake: -D${v}=... missing")
  endif()
endforeach()

function(step name)
  string(TIMESTAMP t "%H:%M:%S")
  message(STATUS "[${t}] ${name}: ${ARGN}")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  set(step_output "${out}${err}" PARENT_SCOPE)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name} failed (exit ${rc}):\n${out}\n${err}")
  endif()
endfunction()

set(config_args)
if(CONFIG)
  set(config_args --config ${CONFIG})
endif()

# 1. Install the build tree into a fresh prefix.
file(REMOVE_RECURSE ${PREFIX} ${CONSUMER_BINARY_DIR} ${CONSUMER_BINARY_DIR}-c)
step("install" ${CMAKE_COMMAND} --install ${BINARY_DIR} --prefix ${PREFIX} ${config_args})

# 2. The layout the package promises (lib may be lib64 under GNUInstallDirs on some systems).
file(GLOB config_file ${PREFIX}/lib*/cmake/flapstab/flapstabConfig.cmake)
file(GLOB version_file ${PREFIX}/lib*/cmake/flapstab/flapstabConfigVersion.cmake)
file(GLOB targets_file ${PREFIX}/lib*/cmake/flapstab/flapstabTargets.cmake)
foreach(f "${config_file}" "${version_file}" "${targets_file}" ${PREFIX}/bin/flapstab ${PREFIX}/include/core/types.hpp
        ${PREFIX}/include/cfd/navier_stokes/grid.hpp ${PREFIX}/include/stability/floquet.hpp
        ${PREFIX}/share/flapstab/insects/hawkmoth.toml ${PREFIX}/share/flapstab/cases/hawkmoth_cfd.toml)
  if(f STREQUAL "" OR NOT EXISTS "${f}")
    message(FATAL_ERROR "not installed: ${f} (looked under ${PREFIX})")
  endif()
endforeach()
file(READ "${config_file}" text)
if(NOT text MATCHES "find_dependency\\(Eigen3")
  message(FATAL_ERROR "${config_file} does not look for Eigen3")
endif()

# 3. A project outside the tree: configure against the prefix only, build, run.
set(flags)
if(SANITIZE)
  # The libraries were compiled with -fsanitize=${SANITIZE}: the consumer must link the sanitizer runtimes too.
  set(flags "-DCMAKE_CXX_FLAGS=-fsanitize=${SANITIZE}" "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=${SANITIZE}")
endif()
set(make_program)
if(MAKE_PROGRAM)
  set(make_program -DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM})
endif()
set(build_type)
if(CONFIG)
  set(build_type -DCMAKE_BUILD_TYPE=${CONFIG})
endif()
step("configure the consumer" ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR} -B ${CONSUMER_BINARY_DIR} -G ${GENERATOR}
     ${make_program} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${build_type} -DCMAKE_PREFIX_PATH=${PREFIX}
     -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF ${flags})
file(STRINGS ${CONSUMER_BINARY_DIR}/CMakeCache.txt found_dir REGEX "^flapstab_DIR:")
string(FIND "${found_dir}" "${PREFIX}/" at)
if(NOT at GREATER -1)
  message(FATAL_ERROR "the consumer found flapstab elsewhere than in ${PREFIX}: ${found_dir}")
endif()
# The same project with C enabled too: the package then finds HDF5 through FindHDF5 (configure only).
step("configure the consumer with C and C++" ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR} -B ${CONSUMER_BINARY_DIR}-c
     -G ${GENERATOR} ${make_program} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${build_type} -DCMAKE_PREFIX_PATH=${PREFIX}
     -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DFLAPSTAB_CONSUMER_WITH_C=ON ${flags})
step("build the consumer" ${CMAKE_COMMAND} --build ${CONSUMER_BINARY_DIR} ${config_args})
file(GLOB_RECURSE consumer_exe ${CONSUMER_BINARY_DIR}/consumer ${CONSUMER_BINARY_DIR}/*/consumer)
list(GET consumer_exe 0 consumer_exe)
step("run the consumer" ${consumer_exe})
message(STATUS "${step_output}")
if(NOT step_output MATCHES "ok: CVODE integrates the monodromy")
  message(FATAL_ERROR "the consumer did not finish its checks")
endif()

# 4. The installed program.
step("flapstab --help" ${PREFIX}/bin/flapstab --help)
if(NOT step_output MATCHES "trim-hover")
  message(FATAL_ERROR "flapstab --help does not list the subcommands:\n${step_output}")
endif()
step("flapstab trim-hover on the installed hawkmoth" ${PREFIX}/bin/flapstab trim-hover
     ${PREFIX}/share/flapstab/insects/hawkmoth.toml --json ${CONSUMER_BINARY_DIR}/trim.json)
if(NOT EXISTS ${CONSUMER_BINARY_DIR}/trim.json)
  message(FATAL_ERROR "flapstab trim-hover wrote no ${CONSUMER_BINARY_DIR}/trim.json")
endif()
message(STATUS "installed package, consumer and program: all passed")
