# ctest driver: install the built tree into a fresh prefix, build the consumer against it with
# find_package and, separately, with pkg-config alone, and run them. With a shared build, the
# programs must load the installed shared libraries.
# Variables: BUILD_DIR, SOURCE_DIR, WORK_DIR, EXTRA_FLAGS (e.g. sanitizer flags), CXX, LIBDIR
# (CMAKE_INSTALL_LIBDIR), SHARED (ON for a shared build).
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(output "${out}" PARENT_SCOPE)
endfunction()
run("install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
set(ENV{LD_LIBRARY_PATH} ${prefix}/${LIBDIR})

# find_package
run("configuring the consumer" ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/consumer
    -B ${WORK_DIR}/build -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_CXX_COMPILER=${CXX} "-DCMAKE_CXX_FLAGS=${EXTRA_FLAGS}"
    "-DCMAKE_EXE_LINKER_FLAGS=${EXTRA_FLAGS}")
run("building the consumer" ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run("the consumer of kanedyn::core" ${WORK_DIR}/build/consumer_core)
run("the consumer of kanedyn::kanedyn" ${WORK_DIR}/build/consumer_io)

# pkg-config: the flags of kanedyn.pc, nothing else (a static kanedyn_io needs libyaml too).
set(ENV{PKG_CONFIG_PATH} ${prefix}/${LIBDIR}/pkgconfig)
if(SHARED)
  set(static "")
else()
  set(static "--static")
endif()
run("pkg-config" pkg-config --cflags --libs ${static} kanedyn)
string(STRIP "${output}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
separate_arguments(extra UNIX_COMMAND "${EXTRA_FLAGS}")
run("compiling with pkg-config's flags" ${CXX} -std=c++20 ${extra}
    ${SOURCE_DIR}/tests/consumer/io_main.cpp ${flags} -o ${WORK_DIR}/consumer_pkgconfig)
run("the consumer built with pkg-config" ${WORK_DIR}/consumer_pkgconfig)

if(SHARED)
  foreach(program build/consumer_io consumer_pkgconfig)
    run("readelf" readelf -d ${WORK_DIR}/${program})
    if(NOT output MATCHES "libkanedyn_io\\.so" OR NOT output MATCHES "libkanedyn_core\\.so")
      message(FATAL_ERROR "${program} does not load kanedyn's shared libraries:\n${output}")
    endif()
  endforeach()
endif()
