# cmake -P script: installs the python component into a scratch prefix and imports sspc from
# there, from a folder where the build tree's package cannot be found by accident.
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR} --component python
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "install failed: ${rc}")
endif()
execute_process(
  COMMAND ${CMAKE_COMMAND} -E env --unset=PYTHONPATH PYTHONPATH=${WORK_DIR}/${INSTALL_DIR}
          ${PYTHON} -c "import sspc; print(sspc.__file__); print(len(sspc.synthetic.sphere(100)))"
  WORKING_DIRECTORY ${WORK_DIR}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc OR NOT out MATCHES "^${WORK_DIR}/${INSTALL_DIR}/sspc/__init__.py\n100\n$")
  message(FATAL_ERROR "importing the installed package failed: ${rc}\n${out}\n${err}")
endif()
message(STATUS "imported ${out}")
