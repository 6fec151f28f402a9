# harvest_add_pytests(path [DEPENDENCIES target...])
#
# Registers the pytest tests under `path` (relative to the package) as the catkin test target
# run_tests_<package>_pytest_<path> (also run by run_tests_<package> and run_tests). The JUnit
# result is ${CATKIN_TEST_RESULTS_DIR}/<package>/pytest-<path>.xml, beside the rostests'.
# <path>/rostest is left out (rostest nodes, whose *_test.py pytest would collect). The
# strict-dependency plugin (harvest_test_utils.strict_deps) is loaded: with HARVEST_STRICT_DEPS=1
# in the environment a skipped test fails unless its reason says the dependency is optional.
# Use inside if(CATKIN_ENABLE_TESTING), after find_package(harvest_test_utils REQUIRED).
function(harvest_add_pytests path)
  cmake_parse_arguments(_hpt "" "" "DEPENDENCIES" ${ARGN})
  if(_hpt_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "harvest_add_pytests() called with unused arguments: ${_hpt_UNPARSED_ARGUMENTS}")
  endif()
  if(IS_ABSOLUTE "${path}")
    set(_dir "${path}")
  else()
    set(_dir "${PROJECT_SOURCE_DIR}/${path}")
  endif()
  if(NOT IS_DIRECTORY "${_dir}")
    message(FATAL_ERROR "harvest_add_pytests(): no directory '${_dir}'")
  endif()
  file(RELATIVE_PATH _name "${PROJECT_SOURCE_DIR}" "${_dir}")
  string(REPLACE "/" "." _name "${_name}")
  set(_xml "pytest-${_name}.xml")
  set(_out "${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}")
  set(_cmd "\"${CMAKE_COMMAND}\" -E make_directory \"${_out}\"")
  list(APPEND _cmd "\"${PYTHON_EXECUTABLE}\" -m pytest -q -p no:cacheprovider -p harvest_test_utils.strict_deps \"${_dir}\" \"--ignore=${_dir}/rostest\" -o junit_family=xunit1 -o junit_suite_name=${PROJECT_NAME} \"--junitxml=${_out}/${_xml}\"")
  catkin_run_tests_target("pytest" ${_name} ${_xml} COMMAND ${_cmd} DEPENDENCIES ${_hpt_DEPENDENCIES})
endfunction()
