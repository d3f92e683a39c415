# Install script (CMakeLists.txt): a venv with rosbags, pylsl and mcap at HRI_SYNC_VENV
# (relative to the install prefix), on HRI_SYNC_PYTHON's site packages.
# pip needs PyPI or a local index; a failure only warns.
set(venv "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}/${HRI_SYNC_VENV}")
if(EXISTS "${venv}/bin/python")
  execute_process(COMMAND "${venv}/bin/python" -c "import rosbags, pylsl, mcap"
    RESULT_VARIABLE missing OUTPUT_QUIET ERROR_QUIET)
  if(NOT missing)
    message(STATUS "Up-to-date: ${venv} (rosbags, pylsl, mcap)")
    return()
  endif()
endif()
message(STATUS "Installing: ${venv} (pip install rosbags pylsl mcap)")
execute_process(
  COMMAND "${HRI_SYNC_PYTHON}" -m venv --system-site-packages "${venv}"
  RESULT_VARIABLE failed)
if(NOT failed)
  execute_process(
    COMMAND "${venv}/bin/pip" install -q --disable-pip-version-check rosbags pylsl mcap
    RESULT_VARIABLE failed)
endif()
if(failed)
  message(WARNING "no rosbags venv at ${venv}: verify_decisions will need "
    "HRI_SYNC_VENV set to a venv with rosbags (pip install rosbags pylsl mcap)")
endif()
