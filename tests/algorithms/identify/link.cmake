# The independent record generator (tests/support/identify) that these tests
# run `identify` on, written apart from algorithms/identify/record_generator.
target_sources(${exe} PRIVATE ${GYROTC_SOURCE_DIR}/tests/support/identify/independent_record.cpp)
target_include_directories(${exe} PRIVATE ${GYROTC_SOURCE_DIR}/tests/support)
