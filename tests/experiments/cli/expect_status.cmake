# Runs CMD (a ;-list) and passes only when it exits with code RC and stdout matches each ;-separated
# regex in REGEX (a run that finished with a status that is not ok: exit 1 with the reason printed).
execute_process(COMMAND ${CMD} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL RC)
  message(FATAL_ERROR "expected exit ${RC}, got ${rc}\nstdout: ${out}\nstderr: ${err}")
endif()
foreach(re IN LISTS REGEX)
  if(NOT out MATCHES "${re}")
    message(FATAL_ERROR "stdout does not match '${re}':\n${out}")
  endif()
endforeach()
