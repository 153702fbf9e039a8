# One module, one folder, one CMake target (docs/architecture.md).
#
#   quadid_module(NAME DEPS other modules... [PUBLIC_LIBS ...] [PRIVATE_LIBS ...])
#
# called from src/NAME/CMakeLists.txt builds every src/NAME/*.cpp into the static
# library quadid_NAME, linked PUBLIC to the modules it names (and so to theirs).
# The declared graph is recorded; quadid_check_module_graph() fails the configure
# on a cycle or on a dependency on an undeclared module, and writes the graph to
# ${CMAKE_BINARY_DIR}/modules.txt (one line "module: deps...") for the tests that
# compare it with the sources' includes and with docs/architecture.md.
set_property(GLOBAL PROPERTY QUADID_MODULES "")

function(quadid_module name)
  cmake_parse_arguments(M "" "" "DEPS;PUBLIC_LIBS;PRIVATE_LIBS" ${ARGN})
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  if(NOT sources)
    message(FATAL_ERROR "quadid_module(${name}): no .cpp in ${CMAKE_CURRENT_SOURCE_DIR}")
  endif()
  set(target quadid_${name})
  add_library(${target} STATIC ${sources})
  target_include_directories(${target} PUBLIC "$<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>"
                                              "$<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>")
  foreach(d IN LISTS M_DEPS)
    target_link_libraries(${target} PUBLIC quadid_${d})
  endforeach()
  target_link_libraries(${target} PUBLIC ${M_PUBLIC_LIBS} PRIVATE ${M_PRIVATE_LIBS})
  target_compile_definitions(${target} PUBLIC QUADID_VERSION="${PROJECT_VERSION}")
  if(QUADID_SANITIZE)
    target_link_options(${target} INTERFACE -fsanitize=address,undefined)
  endif()
  # Position-independent: the Python module links these static libraries into a shared one.
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  set_target_properties(${target} PROPERTIES OUTPUT_NAME quadid_${name} EXPORT_NAME ${name})
  set_property(GLOBAL APPEND PROPERTY QUADID_MODULES ${name})
  set_property(GLOBAL PROPERTY QUADID_DEPS_${name} "${M_DEPS}")
endfunction()

# Depth-first search over the declared graph: a module met again while it is
# still on the path closes a cycle.
function(_quadid_visit name path)
  get_property(done GLOBAL PROPERTY QUADID_DONE_${name})
  if(done)
    return()
  endif()
  list(FIND path ${name} at)
  if(NOT at EQUAL -1)
    list(SUBLIST path ${at} -1 cycle)
    list(APPEND cycle ${name})
    list(JOIN cycle " -> " text)
    message(FATAL_ERROR "quadid modules: dependency cycle ${text} (docs/architecture.md: dependencies go one way)")
  endif()
  list(APPEND path ${name})
  get_property(deps GLOBAL PROPERTY QUADID_DEPS_${name})
  get_property(all GLOBAL PROPERTY QUADID_MODULES)
  foreach(d IN LISTS deps)
    if(NOT d IN_LIST all)
      message(FATAL_ERROR "quadid module ${name} depends on '${d}', which is not a module (src/${d}/CMakeLists.txt?)")
    endif()
    _quadid_visit(${d} "${path}")
  endforeach()
  set_property(GLOBAL PROPERTY QUADID_DONE_${name} TRUE)
endfunction()

function(quadid_check_module_graph)
  get_property(all GLOBAL PROPERTY QUADID_MODULES)
  set(lines "")
  foreach(m IN LISTS all)
    _quadid_visit(${m} "")
    get_property(deps GLOBAL PROPERTY QUADID_DEPS_${m})
    list(JOIN deps " " d)
    string(APPEND lines "${m}: ${d}\n")
  endforeach()
  file(WRITE ${CMAKE_BINARY_DIR}/modules.txt "${lines}")
  set(QUADID_MODULE_LIST ${all} PARENT_SCOPE)
endfunction()
