# Runs CMD (a ;-list) and passes only when it exits 0 with stdout matching every regex in REGEX
# (a ;-list; an unbalanced square bracket in a regex would stop the list from splitting).
execute_process(COMMAND ${CMD} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "exit ${rc}\nstdout: ${out}\nstderr: ${err}")
endif()
foreach(re IN LISTS REGEX)
  if(NOT out MATCHES "${re}")
    message(FATAL_ERROR "stdout does not match '${re}':\n${out}")
  endif()
endforeach()
message(STATUS "${out}")
