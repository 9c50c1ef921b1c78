# Debian ships OpenCVConfig.cmake only in libopencv-dev, which pulls in Qt and VTK. We use the
# component packages (libopencv-core-dev, ...) and make imported targets named like OpenCV's.
find_path(OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
foreach(part core imgproc imgcodecs videoio features2d)
  find_library(OPENCV_${part}_LIBRARY NAMES opencv_${part})
  if(OPENCV_${part}_LIBRARY AND NOT TARGET opencv_${part})
    add_library(opencv_${part} SHARED IMPORTED)
    set_target_properties(opencv_${part} PROPERTIES
      IMPORTED_LOCATION ${OPENCV_${part}_LIBRARY}
      INTERFACE_INCLUDE_DIRECTORIES ${OPENCV_INCLUDE_DIR})
  endif()
endforeach()
foreach(required core imgproc imgcodecs)
  if(NOT TARGET opencv_${required})
    message(FATAL_ERROR "libopencv-${required}-dev is missing: run scripts/bootstrap")
  endif()
endforeach()
