# cansim_find_python(VAR "IMPORTS" "PACKAGES" DOC): sets the cache variable
# VAR to a python3 that can `import IMPORTS` (a comma-separated module list).
# Debian's python3-* packages are installed for Debian's python3: prefer
# /usr/bin/python3 over whatever python3 comes first in PATH (pyenv, venvs).
# Without one, warns naming the Debian PACKAGES and falls back to
# /usr/bin/python3 (the tests that need it then fail, saying why).
function(cansim_find_python var imports packages doc)
  if(${var})
    return()
  endif()
  find_program(_cansim_path_python3 NAMES python3)
  foreach(py /usr/bin/python3 ${_cansim_path_python3})
    if(EXISTS ${py})
      execute_process(COMMAND ${py} -c "import ${imports}" RESULT_VARIABLE rc OUTPUT_QUIET ERROR_QUIET)
      if(rc EQUAL 0)
        set(${var} ${py} CACHE FILEPATH "${doc}" FORCE)
        return()
      endif()
    endif()
  endforeach()
  message(WARNING "No python3 that can import ${imports} (apt-get install ${packages}): ${doc} will fail")
  set(${var} /usr/bin/python3 CACHE FILEPATH "${doc}" FORCE)
endfunction()

# cansim_script_tests(PREFIX LABEL ENVIRONMENT [PROPERTIES...]): every
# test_*.py of the calling folder as the ctest PREFIX<name> with LABEL, run by
# ${CANSIM_IT_PYTHON} with --cansimd "<the built cansimd or "">" --source-dir
# --binary-dir, ENVIRONMENT (a ;-list) and PROPERTIES (more ctest
# properties); each exits 0 pass / 1 fail / 77 skip, its time limit 300 s
# unless a line "# ctest-timeout: SECONDS" says otherwise.
function(cansim_script_tests prefix label environment)
  set(daemon "")
  if(TARGET cansimd)
    set(daemon "$<TARGET_FILE:cansimd>")
  endif()
  file(GLOB tests CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/test_*.py)
  foreach(t ${tests})
    get_filename_component(n ${t} NAME_WE)
    string(REGEX REPLACE "^test_" "" n ${n})
    set(timeout 300)
    file(STRINGS ${t} timeout_line REGEX "^# ctest-timeout: *[0-9]+" LIMIT_COUNT 1)
    if(timeout_line)
      string(REGEX REPLACE "^# ctest-timeout: *([0-9]+).*" "\\1" timeout "${timeout_line}")
    endif()
    add_test(NAME ${prefix}${n}
             COMMAND ${CANSIM_IT_PYTHON} ${t} --cansimd "${daemon}" --source-dir ${CMAKE_SOURCE_DIR}
                     --binary-dir ${CMAKE_BINARY_DIR}
             WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
    set_tests_properties(${prefix}${n} PROPERTIES LABELS ${label} SKIP_RETURN_CODE 77 TIMEOUT ${timeout}
      ENVIRONMENT "CANSIMD=${daemon};CANSIM_SOURCE_DIR=${CMAKE_SOURCE_DIR};CANSIM_BINARY_DIR=${CMAKE_BINARY_DIR};PYTHONDONTWRITEBYTECODE=1;PYTHONUNBUFFERED=1;${environment}"
      ${ARGN})
  endforeach()
endfunction()
