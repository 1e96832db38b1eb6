# The test example.embree (cmake -P): encodes CLOUD at level 5, renders the model through the
# Embree example (EXAMPLE) at 256×256 and `sspc render` (SSPC) of the same model from the same
# camera, and compares them with `sspc render --compare` (docs/METRICS.md, "Images"). The example
# reproduces sspc's camera and shading, and RenderScene::intersect is the surface render() traces,
# so the images agree up to rounding: at least 35 dB over the pixels both hit, at most 0.5% of
# the pixels hit in one image only.
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "${ARGN}\nexit ${code}\n${out}${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()

run("${SSPC}" --quiet encode "${CLOUD}" "${WORK}/bunny.sspc" --level 5)
run("${EXAMPLE}" "${WORK}/bunny.sspc" "${WORK}/embree.png" 256)
run("${SSPC}" --quiet render "${WORK}/bunny.sspc" -o "${WORK}/sspc.png" --size 256x256 --compare "${WORK}/embree.png"
    --json)
string(JSON hit_both GET "${out}" hit_both)
string(JSON one_only GET "${out}" hit_one_only_fraction)
string(JSON psnr_type TYPE "${out}" psnr_hit_db)
if(psnr_type STREQUAL "NULL")
  set(psnr inf)  # the images agree exactly over the pixels both hit
else()
  string(JSON psnr GET "${out}" psnr_hit_db)
endif()
message(STATUS "Embree example against sspc render: ${psnr} dB over ${hit_both} pixels hit by both, "
               "fraction ${one_only} of the pixels hit in one only")
if(hit_both LESS 5000)
  message(FATAL_ERROR "only ${hit_both} pixels hit by both images: the bunny does not fill the view")
endif()
if(NOT psnr STREQUAL "inf" AND psnr LESS 35)
  message(FATAL_ERROR "image PSNR ${psnr} dB over the pixels both hit, below 35 dB")
endif()
if(one_only GREATER 0.005)
  message(FATAL_ERROR "${one_only} of the pixels are hit in one image only, above 0.005")
endif()
