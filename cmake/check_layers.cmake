# cmake -DSOURCE_DIR=... -P check_layers.cmake: dependencies point down. The library folders from the
# bottom up (each may include its own headers and those of the folders before it, never one after):
# the order of core/CMakeLists.txt, then the simulator and its layers, then the programs. The two
# front-ends of the identification, python and experiments/cli, are siblings over experiments/request;
# python is listed first so that it includes nothing of the command line.
# Fails naming every #include "..." that points up (a file's folder is the longest one listed that
# holds it).
set(layers
  core/stats core/model core/io core/estimators core/sets core/detectors core/identify core/select core/model_file
  core/builtin
  sim sim/sensitivity sim/refine sim/events sim/model_check
  experiments/sweep experiments/request python experiments/cli)

function(layer_of path out)
  set(best -1)
  set(best_len 0)
  set(i 0)
  foreach(layer IN LISTS layers)
    string(LENGTH "${layer}" len)
    if(path MATCHES "^${layer}/" AND len GREATER best_len)
      set(best ${i})
      set(best_len ${len})
    endif()
    math(EXPR i "${i} + 1")
  endforeach()
  set(${out} ${best} PARENT_SCOPE)
endfunction()

set(violations "")
file(GLOB_RECURSE sources RELATIVE ${SOURCE_DIR} ${SOURCE_DIR}/core/*.[ch]pp ${SOURCE_DIR}/sim/*.[ch]pp
                                                 ${SOURCE_DIR}/experiments/*.[ch]pp ${SOURCE_DIR}/python/*.[ch]pp)
foreach(source IN LISTS sources)
  layer_of(${source} own)
  if(own LESS 0)
    string(APPEND violations "\n  ${source}: in no layer (add its folder to cmake/check_layers.cmake)")
    continue()
  endif()
  file(STRINGS ${SOURCE_DIR}/${source} includes REGEX "^#include \"")
  foreach(line IN LISTS includes)
    string(REGEX REPLACE "^#include \"([^\"]*)\".*" "\\1" header "${line}")
    layer_of(${header} target)
    if(target GREATER own)
      list(GET layers ${own} own_name)
      list(GET layers ${target} target_name)
      string(APPEND violations "\n  ${source} (${own_name}) includes ${header} (${target_name}, a layer above)")
    endif()
  endforeach()
endforeach()
if(violations)
  message(FATAL_ERROR "includes that point up:${violations}")
endif()
list(LENGTH sources count)
message(STATUS "${count} files: every include points down")
