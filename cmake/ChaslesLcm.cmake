# chasles_lcm_types(<target> SOURCES <file.lcm>... [JAR <name>])
#
# Generates C++ headers from LCM message definitions at build time, as LCM's own lcm_wrap_types
# does, and makes <target> an INTERFACE library that carries them: consumers link <target> and
# write #include <package/type_t.hpp>.
#
#   headers  ${CMAKE_CURRENT_BINARY_DIR}/include/<package>/<type>.hpp (lcm-gen -x --cpp-std c++11),
#            on <target>'s include path as SYSTEM: lcm-gen's output trips -Wold-style-cast and
#            -Wsign-conversion, and our warnings are errors.
#   JAR      with a JDK and LCM's lcm.jar, also ${CMAKE_CURRENT_BINARY_DIR}/<name>.jar (lcm-gen -j,
#            javac, jar), built as part of ALL, for lcm-spy and Java tools; skipped with a STATUS
#            message otherwise.
#
# Sets <target>_INCLUDE_DIR and, when the jar is built, <target>_JAR in the caller's scope.
# Needs the imported target PkgConfig::LCM (pkg_check_modules(LCM REQUIRED IMPORTED_TARGET lcm)).

find_program(CHASLES_LCM_GEN lcm-gen DOC "LCM's code generator (Debian: liblcm-bin)")
find_file(CHASLES_LCM_JAR lcm.jar PATHS /usr/share/java /usr/local/share/java
          DOC "LCM's Java library (Debian: liblcm-java), needed for the types jar")

# The outputs lcm-gen writes for one .lcm file, read from its package and struct declarations.
function(_chasles_lcm_outputs lcm_file cpp_dir java_dir cpp_var java_var)
  file(STRINGS ${lcm_file} package_line REGEX "^[ \t]*package[ \t]+[A-Za-z0-9_.]+[ \t]*;")
  file(STRINGS ${lcm_file} struct_lines REGEX "^[ \t]*struct[ \t]+[A-Za-z0-9_]+")
  if(NOT package_line OR NOT struct_lines)
    message(FATAL_ERROR "${lcm_file}: needs a 'package NAME;' line and at least one 'struct NAME' line")
  endif()
  string(REGEX REPLACE "^[ \t]*package[ \t]+([A-Za-z0-9_.]+).*" "\\1" package "${package_line}")
  string(REPLACE "." "/" package_dir "${package}")
  set(cpp "")
  set(java "")
  foreach(line IN LISTS struct_lines)
    string(REGEX REPLACE "^[ \t]*struct[ \t]+([A-Za-z0-9_]+).*" "\\1" type "${line}")
    list(APPEND cpp ${cpp_dir}/${package_dir}/${type}.hpp)
    list(APPEND java ${java_dir}/${package_dir}/${type}.java)
  endforeach()
  set(${cpp_var} ${cpp} PARENT_SCOPE)
  set(${java_var} ${java} PARENT_SCOPE)
endfunction()

function(chasles_lcm_types target)
  cmake_parse_arguments(ARG "" "JAR" "SOURCES" ${ARGN})
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "chasles_lcm_types(${target}): no SOURCES")
  endif()
  if(NOT CHASLES_LCM_GEN)
    message(FATAL_ERROR "lcm-gen not found: install it (Debian: apt-get install liblcm-bin)")
  endif()
  if(NOT TARGET PkgConfig::LCM)
    message(FATAL_ERROR "chasles_lcm_types needs PkgConfig::LCM: pkg_check_modules(LCM REQUIRED IMPORTED_TARGET lcm)")
  endif()

  set(cpp_dir ${CMAKE_CURRENT_BINARY_DIR}/include)
  set(java_dir ${CMAKE_CURRENT_BINARY_DIR}/java)
  set(sources "")
  set(headers "")
  set(java_sources "")
  foreach(source IN LISTS ARG_SOURCES)
    get_filename_component(source ${source} ABSOLUTE)
    list(APPEND sources ${source})
    _chasles_lcm_outputs(${source} ${cpp_dir} ${java_dir}/src cpp java)
    list(APPEND headers ${cpp})
    list(APPEND java_sources ${java})
    # The outputs are read from the sources: a new struct must reach the build graph.
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${source})
  endforeach()

  add_custom_command(
    OUTPUT ${headers}
    COMMAND ${CHASLES_LCM_GEN} -x --cpp-std c++11 --cpp-hpath ${cpp_dir} ${sources}
    DEPENDS ${sources}
    COMMENT "lcm-gen: C++ headers for ${target}"
    VERBATIM)
  add_custom_target(${target}_cpp DEPENDS ${headers})

  add_library(${target} INTERFACE)
  # Dependencies of an interface library are followed by whatever links it, so headers are
  # generated before any consumer compiles.
  add_dependencies(${target} ${target}_cpp)
  target_include_directories(${target} SYSTEM INTERFACE $<BUILD_INTERFACE:${cpp_dir}>
                                                        $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${target} INTERFACE PkgConfig::LCM)
  set(${target}_INCLUDE_DIR ${cpp_dir} PARENT_SCOPE)

  if(NOT ARG_JAR)
    return()
  endif()
  find_package(Java COMPONENTS Development QUIET)
  if(NOT Java_JAVAC_EXECUTABLE OR NOT Java_JAR_EXECUTABLE OR NOT CHASLES_LCM_JAR)
    message(STATUS "${ARG_JAR}.jar skipped: needs a JDK (javac, jar) and LCM's lcm.jar "
                   "(Debian: default-jdk-headless liblcm-java)")
    return()
  endif()
  set(jar ${CMAKE_CURRENT_BINARY_DIR}/${ARG_JAR}.jar)
  # Classes are compiled afresh so a removed type does not linger in the jar.
  add_custom_command(
    OUTPUT ${jar}
    COMMAND ${CMAKE_COMMAND} -E remove_directory ${java_dir}
    COMMAND ${CHASLES_LCM_GEN} -j --jpath ${java_dir}/src ${sources}
    COMMAND ${Java_JAVAC_EXECUTABLE} -nowarn -encoding UTF-8 -cp ${CHASLES_LCM_JAR} -d ${java_dir}/classes
            ${java_sources}
    COMMAND ${Java_JAR_EXECUTABLE} cf ${jar} -C ${java_dir}/classes .
    DEPENDS ${sources}
    COMMENT "lcm-gen, javac, jar: ${ARG_JAR}.jar"
    VERBATIM)
  add_custom_target(${target}_jar ALL DEPENDS ${jar})
  set(${target}_JAR ${jar} PARENT_SCOPE)
endfunction()
