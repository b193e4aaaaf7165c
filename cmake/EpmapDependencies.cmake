# Every third-party dependency, found once. All come from Debian 12 packages
# (scripts/install-deps.sh installs them).

find_package(Threads REQUIRED)
find_package(GTest)
find_package(benchmark)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(OpenCV 4.6 REQUIRED COMPONENTS core imgproc imgcodecs calib3d features2d ml)
find_package(fastcdr REQUIRED)
find_package(fastrtps 2.9 REQUIRED)
find_package(Protobuf REQUIRED)
find_package(gRPC CONFIG REQUIRED)
find_package(NLopt REQUIRED)
find_package(spdlog REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(orocos_kdl REQUIRED)
find_package(urdfdom REQUIRED)
find_package(SQLite3 REQUIRED)
find_path(CLI11_INCLUDE_DIR CLI/CLI.hpp REQUIRED)
find_library(KDL_PARSER_LIBRARY kdl_parser REQUIRED)
find_path(KDL_PARSER_INCLUDE_DIR kdl_parser/kdl_parser.hpp REQUIRED)

find_program(FASTDDSGEN fastddsgen REQUIRED)
find_program(GRPC_CPP_PLUGIN grpc_cpp_plugin REQUIRED)

# Imported targets for the packages that only export variables.
if(NOT TARGET epmap::cli11)
  add_library(epmap::cli11 INTERFACE IMPORTED)
  target_include_directories(epmap::cli11 INTERFACE ${CLI11_INCLUDE_DIR})
endif()
if(NOT TARGET epmap::kdl)
  add_library(epmap::kdl INTERFACE IMPORTED)
  target_include_directories(epmap::kdl SYSTEM INTERFACE ${orocos_kdl_INCLUDE_DIRS}
                             ${KDL_PARSER_INCLUDE_DIR} ${urdfdom_INCLUDE_DIRS})
  target_link_libraries(epmap::kdl INTERFACE ${KDL_PARSER_LIBRARY} ${orocos_kdl_LIBRARIES}
                        ${urdfdom_LIBRARIES})
endif()
if(NOT TARGET epmap::opencv)
  add_library(epmap::opencv INTERFACE IMPORTED)
  target_include_directories(epmap::opencv SYSTEM INTERFACE ${OpenCV_INCLUDE_DIRS})
  target_link_libraries(epmap::opencv INTERFACE ${OpenCV_LIBS})
endif()
