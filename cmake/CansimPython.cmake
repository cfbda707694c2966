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
