# Script run by the install.find_package test (see examples/cpp/CMakeLists.txt).
file(REMOVE_RECURSE ${PREFIX} ${CONSUMER_BUILD} ${CORE_CONSUMER_BUILD})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${PREFIX}
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc})")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE} -B ${CONSUMER_BUILD}
                        -DCMAKE_PREFIX_PATH=${PREFIX} -DCMAKE_BUILD_TYPE=Release
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring the consumer project failed (${rc})")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${CONSUMER_BUILD} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the consumer project failed (${rc})")
endif()
execute_process(COMMAND ${CONSUMER_BUILD}/consumer ${MODEL} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the consumer program failed (${rc})")
endif()
# A project that asks for the core alone (find_package(dronetwin COMPONENTS core), links
# dronetwin::core): it must configure, build and run without Ceres or yaml-cpp being looked for.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${CORE_CONSUMER_SOURCE} -B ${CORE_CONSUMER_BUILD}
                        -DCMAKE_PREFIX_PATH=${PREFIX} -DCMAKE_BUILD_TYPE=Release
                        -DCMAKE_DISABLE_FIND_PACKAGE_Ceres=ON
                        -DCMAKE_DISABLE_FIND_PACKAGE_yaml-cpp=ON
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring the core-only consumer project failed (${rc})")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${CORE_CONSUMER_BUILD} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the core-only consumer project failed (${rc})")
endif()
execute_process(COMMAND ${CORE_CONSUMER_BUILD}/core_consumer RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the core-only consumer program failed (${rc})")
endif()
# The installed Python package imports from the prefix alone and loads a model.
if(PYTHON AND PYTHON_DIR)
  execute_process(
    COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${PREFIX}/${PYTHON_DIR} PYTHONDONTWRITEBYTECODE=1
            ${PYTHON} -c "import dronetwin, sys; assert dronetwin.__file__.startswith(sys.argv[1]), dronetwin.__file__; m = dronetwin.load_model(sys.argv[2]); s = dronetwin.Simulator(m); s.reset(dronetwin.Simulator.hover_state([0, 0, 1]), m.hover_speeds_rad_s()); assert s.step(100).ok; print('installed python package OK:', dronetwin.__file__)"
            ${PREFIX} ${MODEL}
    RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "the installed Python package failed (${rc})")
  endif()
endif()
