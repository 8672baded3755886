# One module = one library target. A module's folder holds include/densemap/<name>/ (its public headers,
# visible only to modules that link it), src/, and its CMakeLists.txt, which lists its sources once:
#
#   densemap_module(map
#     SOURCES src/grid_map.cpp ...          # none: a header-only (INTERFACE) module
#     DEPENDS geometry util                 # densemap modules its public headers need
#     PRIVATE_DEPENDS options               # densemap modules only its sources need
#     LIBS Eigen3::Eigen                    # outside libraries its public headers need
#     PRIVATE_LIBS PNG::PNG)                # outside libraries only its sources need
#
# The layering is written once, in DENSEMAP_LAYERS (the top-level CMakeLists.txt): a module may link only
# modules of lower layers. densemap_check_layering() (called once every module exists) checks every
# module's links, made here or by hand, and stops the configuration naming the arrow that runs up.

function(densemap_layer_of module out)
  set(index 0)
  foreach(layer IN LISTS DENSEMAP_LAYERS)
    string(REPLACE " " ";" members "${layer}")
    if(module IN_LIST members)
      set(${out} ${index} PARENT_SCOPE)
      return()
    endif()
    math(EXPR index "${index} + 1")
  endforeach()
  set(${out} -1 PARENT_SCOPE)
endfunction()

function(densemap_module name)
  cmake_parse_arguments(M "" "" "SOURCES;DEPENDS;PRIVATE_DEPENDS;LIBS;PRIVATE_LIBS" ${ARGN})
  densemap_layer_of(${name} layer)
  if(layer LESS 0)
    message(FATAL_ERROR "module '${name}' is in no layer of DENSEMAP_LAYERS (top-level CMakeLists.txt)")
  endif()
  set(target densemap_${name})
  list(TRANSFORM M_DEPENDS PREPEND densemap_ OUTPUT_VARIABLE public_modules)
  list(TRANSFORM M_PRIVATE_DEPENDS PREPEND densemap_ OUTPUT_VARIABLE private_modules)
  if(M_SOURCES)
    add_library(${target} STATIC ${M_SOURCES})
    target_include_directories(${target} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
                                         PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
    target_link_libraries(${target} PUBLIC ${public_modules} ${M_LIBS}
                                    PRIVATE ${private_modules} ${M_PRIVATE_LIBS})
    target_compile_options(${target} PRIVATE ${DENSEMAP_WARNINGS})
    target_compile_options(${target} PUBLIC ${DENSEMAP_FP_FLAGS})
  else()
    if(M_PRIVATE_DEPENDS OR M_PRIVATE_LIBS)
      message(FATAL_ERROR "module '${name}' has no sources, so nothing private to link")
    endif()
    add_library(${target} INTERFACE)
    target_include_directories(${target} INTERFACE ${CMAKE_CURRENT_SOURCE_DIR}/include)
    target_link_libraries(${target} INTERFACE ${public_modules} ${M_LIBS})
    target_compile_options(${target} INTERFACE ${DENSEMAP_FP_FLAGS})
  endif()
  add_library(densemap::${name} ALIAS ${target})
  set_property(GLOBAL APPEND PROPERTY DENSEMAP_MODULES ${name})
endfunction()

# Every densemap_<module> that a module links, directly (made by densemap_module or by hand).
function(densemap_linked_modules target out)
  set(found)
  foreach(property LINK_LIBRARIES INTERFACE_LINK_LIBRARIES)
    get_target_property(type ${target} TYPE)
    if(type STREQUAL "INTERFACE_LIBRARY" AND property STREQUAL "LINK_LIBRARIES")
      continue()
    endif()
    get_target_property(libs ${target} ${property})
    foreach(lib IN LISTS libs)
      string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" lib "${lib}")
      string(REGEX REPLACE "^densemap::" "densemap_" lib "${lib}")
      if(lib MATCHES "^densemap_(.+)$")
        list(APPEND found ${CMAKE_MATCH_1})
      endif()
    endforeach()
  endforeach()
  list(REMOVE_DUPLICATES found)
  set(${out} ${found} PARENT_SCOPE)
endfunction()

function(densemap_check_layering)
  get_property(modules GLOBAL PROPERTY DENSEMAP_MODULES)
  set(problems)
  foreach(module IN LISTS modules)
    densemap_layer_of(${module} layer)
    densemap_linked_modules(densemap_${module} linked)
    foreach(other IN LISTS linked)
      densemap_layer_of(${other} other_layer)
      if(other_layer LESS 0)
        continue()  # not a module (a generated or helper library)
      endif()
      if(NOT other_layer LESS layer)
        list(APPEND problems "module '${module}' (layer ${layer}) links '${other}' (layer ${other_layer})")
      endif()
    endforeach()
  endforeach()
  if(problems)
    list(JOIN problems "\n  " text)
    message(FATAL_ERROR "the layering (DENSEMAP_LAYERS, top-level CMakeLists.txt) is broken: a module may "
                        "link only modules of lower layers:\n  ${text}")
  endif()
endfunction()

# A libFuzzer target of the module whose CMakeLists.txt declares it: fuzz/<name>.cpp, with an optional
# fuzz/<name>.dict and seeds in fuzz/corpus/<name>/ beside it (tools/fuzz.sh finds them through
# <build>/fuzz/<name>.source). Built only with -DDENSEMAP_FUZZ=ON (clang), where every module is compiled
# for fuzzing. SEED_MAKER: a plain program that writes seeds (no fuzzing engine).
function(densemap_fuzz_target name)
  cmake_parse_arguments(F "SEED_MAKER" "" "LINKS;INCLUDES" ${ARGN})
  if(NOT DENSEMAP_FUZZ)
    return()
  endif()
  add_executable(${name} fuzz/${name}.cpp)
  target_link_libraries(${name} PRIVATE ${F_LINKS})
  target_include_directories(${name} PRIVATE ${F_INCLUDES})
  target_compile_options(${name} PRIVATE ${DENSEMAP_WARNINGS})
  if(NOT F_SEED_MAKER)
    target_link_options(${name} PRIVATE -fsanitize=fuzzer)
  endif()
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/fuzz)
  file(WRITE ${CMAKE_BINARY_DIR}/fuzz/${name}.source "${CMAKE_CURRENT_SOURCE_DIR}/fuzz\n")
  add_dependencies(densemap_fuzz_targets ${name})
endfunction()
