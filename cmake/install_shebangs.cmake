# Install script (CMakeLists.txt): give every installed script of
# HRI_SYNC_BIN_DIR whose first line is "#!/usr/bin/env python[3]" the
# shebang "#!HRI_SYNC_PYTHON".
file(GLOB programs
  "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}/${HRI_SYNC_BIN_DIR}/*")
foreach(program ${programs})
  if(IS_DIRECTORY "${program}")
    continue()
  endif()
  file(READ "${program}" head LIMIT 2)
  if(NOT head MATCHES "^#!")
    continue()
  endif()
  execute_process(
    COMMAND sed -i
      "1s|^#![ \t]*/usr/bin/env[ \t]\\+python3\\?[ \t]*$|#!${HRI_SYNC_PYTHON}|"
      "${program}"
    RESULT_VARIABLE failed)
  if(failed)
    message(FATAL_ERROR "cannot set the shebang of ${program}")
  endif()
endforeach()
