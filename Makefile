# Shift-invariant rendering: the project's make driver.
#   make             set up what is missing, build, render the default scene
#                    and form its images, one per method, then print a summary
#   make all-scenes  the same for every scene in scenes/
#   make test        set up, build, run every test (ctest)
#   make compare     accuracy against speed, every scene and method: out/report/
#   make compare-samples  the sample patterns compared: out/report/samples/
#   make render      the render of SCENE alone (with SAMPLES, SEED...)
#   make anim        an animation of SCENE: sub-frames, space-time frames and
#                    videos (FRAMES, SUBFRAMES, FPS...: see "anim" below);
#                    make anim-subframes: the sub-frames alone
#   make compare-anim  the animation study: out/report/anim/
#   make stability   where the methods fail: out/report/stability/
#   make bench       speed and memory against oiiotool and splineops: out/bench/
#   make install     build, then install into PREFIX (default /usr/local):
#                    bin/siproject and bin/simetrics, the library and its
#                    headers with a CMake package (find_package(sis)), and the
#                    Python module where INSTALL_PYTHON (default python3) looks
#                    under PREFIX (Debian's: lib/pythonX.Y/dist-packages), or,
#                    where it does not look, lib/pythonX.Y/site-packages and a
#                    note of how to use it (pip install . builds a wheel instead)
#   make docs        refresh the snapshots committed in docs/ from the latest
#                    reports in out/ (make compare, make bench) and the
#                    default scene's images (the README's picture)
#   make clean       remove the build folder and out/
#
# Variables (make VAR=value):
#   SCENE=checker    scene name: $(SCENEDIR)/$(SCENE).pov (SCENEDIR=scenes)
#   RES=1000         output size: N (N x N) or WxH
#   FACTOR=4         supersampling factor per axis: POV-Ray renders
#                    round(RES * FACTOR) pixels per axis with antialiasing off,
#                    FACTOR^2 rays per output pixel
#   METHODS=...      methods to form (default: all of them, see METHOD_OPTS_*)
#   CUTOFFS=0.125 0.25   high-pass cutoffs (cycles/pixel) in the summary
#   SIFLAGS=         extra siproject options for every method (--boundary periodic)
#   POVOPTS=         extra POV-Ray options for every render (Declare=X=1)
#   ZP_NYQUIST=0.7   zoneplate only: local frequency at the middle of the left
#                    and right edges, as a fraction of Nyquist at output size
#   SAMPLES=regular  where the rays go (sis/pattern.h): regular (POV-Ray's own
#                    camera, one ray through each pixel centre of the
#                    supersampled render), jitter (one uniform ray in each of
#                    its cells) or sobol (Owen-scrambled Sobol' points); the
#                    last two trace through a mesh camera (build/tools/sirays)
#                    in bands of at most MESH_RAYS rays, and write to
#                    $(OUT)/SCENE-SAMPLES-sSEED/
#   SEED=0           the pattern's seed (jitter, sobol)
#   RULE=auto        jitter, sobol, adaptive: how me-cubic, me-cubic-2x2,
#                    hex-quartic and hex-hat (first order) fit the
#                    scattered rays (siproject --rule): fit,
#                    variational (the smoothing spline, lambda by GCV), or
#                    auto: variational below 4 rays per pixel (FACTOR^2, or
#                    RAYS), fit from 4 (docs/studies.md "Adaptive rays");
#                    the other methods keep their own rule
#   MESH_RAYS=2000000  rays per mesh band (one POV-Ray process each, make -j)
#   TILES=1          render in TILES row bands, each its own POV-Ray process
#                    (+SR/+ER, cropped to its rows with oiiotool): with make -j
#                    they render in parallel, and a make-driven farm can send
#                    them to other machines; siproject projects the bands as one
#                    image, equal to the single render's result
#   FARM=local       where TILES bands run: local (this machine, make -j),
#                    slurm (an sbatch job array of band jobs, each rendering
#                    its rows and writing their partials, and a dependent
#                    merge job forming the images; make waits and checks
#                    them) or slurm-submit (submit both, print the job ids,
#                    return); logs in $(OUT)/farm/SCENE-RES-fFACTOR-tilesK/logs/
#   SLURM_ARGS=      extra sbatch options for every job (--partition=P
#                    --account=A --time=1:00:00)
#   FARM_CPUS=1      cores per task: sbatch --cpus-per-task, POV-Ray +WT,
#                    siproject --threads
#   POV_THREADS=     POV-Ray's threads per render (+WT); by default every core
#                    for a whole render and 1 for each band (TILES > 1, which
#                    make -j runs in parallel). One thread renders the same
#                    pixels on every run; more can differ from run to run in a
#                    few pixels of soft shadows (POV-Ray 3.7's shadow cache,
#                    docs/pipeline.md), so a split equals the single render bit
#                    for bit when both render with one (POV_THREADS=1)
#   OUT=out  BUILD=build  JOBS=$(nproc)
#   RENDER_REPEATS=1 a render under 3 s is timed up to this many times (the
#                    smallest wall time kept in its .stats; not an option of
#                    the render: changing it remakes nothing)
#   SIPROJECT=, SIMETRICS=  use these binaries as they are (no setup or build)
#
# Files:
#   $(OUT)/render/SCENE-RES-fFACTOR.exr   POV-Ray's render (half float, linear)
#   $(OUT)/render/SCENE-RES-fFACTOR.stats its statistics, lines NAME VALUE
#                    (scripts/render.sh): wall_s, wall_runs, parse_s, trace_s,
#                    pixels, samples; of a pattern's render the sums over its
#                    mesh bands (each band's own beside it) with rays, mesh_s
#                    (sirays mesh's wall time), mesh_bytes and bands
#   $(OUT)/render/SCENE-RES-fFACTOR-bandIofK.exr   its row bands (TILES=K)
#   $(OUT)/SCENE/METHOD.exr, .png, .log   float result, 8-bit sRGB image,
#                                         siproject -v output (stage times)
#   $(OUT)/SCENE/summary.txt, .csv        time and high-pass share per method
#   $(OUT)/render/SCENE-RES-fFACTOR-SAMPLES-sSEED.exr   the mesh bands' renders
#                    assembled, the pattern in its metadata (SAMPLES not regular;
#                    the bands ...-meshIofK.exr, their scenes removed once rendered)
# A render is redone when its scene, povray.ini, size, factor or POV-Ray
# options change; an image when its render, siproject or its options change.
# Hidden stamp files (.NAME.cmd) hold the options each file was made with.
# The studies (compare, compare-hex, compare-samples, stability, bench) get
# their renders from this rule alone: each runs make render OUT=its folder
# SCENE=... RES=... FACTOR=... [POVOPTS=... SAMPLES=...] with the binaries
# given (scripts/renders.py), and reads the render's times from its .stats.
BUILD ?= build
JOBS  ?= $(shell nproc)
OUT   ?= out

PYTHON ?= .venv/bin/python
SCENE  ?= checker
RES    ?= 1000
FACTOR ?= 4
METHODS ?= box conv-tent me-tent mitchell me-cubic me-tent-2x2 me-cubic-2x2
CUTOFFS ?= 0.125 0.25
SIFLAGS ?=
RULE ?= auto
POVOPTS ?=
ZP_NYQUIST ?= 0.7
SCENEDIR ?= scenes
TILES ?= 1
FARM ?= local
SLURM_ARGS ?=
FARM_CPUS ?= 1
POV_THREADS ?=
SAMPLES ?= regular
SEED ?= 0
MESH_RAYS ?= 2000000
RENDER_REPEATS ?= 1

# siproject options of each method. Every choice is spelled out: siproject's
# default display for min-error is 2x2, so the plain min-error methods say
# centred. Box: the normalised average over the pixel, which equals min-error
# box (docs/design.md section 3).
METHOD_OPTS_box          := --generator box --method conventional --display centred
METHOD_OPTS_conv-tent    := --generator tent --method conventional --display centred
METHOD_OPTS_me-tent      := --generator tent --method min-error --display centred
METHOD_OPTS_mitchell     := --generator mitchell --method conventional --display centred
METHOD_OPTS_me-cubic     := --generator cubic --method min-error --display centred
METHOD_OPTS_me-tent-2x2  := --generator tent --method min-error --display 2x2
METHOD_OPTS_me-cubic-2x2 := --generator cubic --method min-error --display 2x2
# The hexagonal lattice (not in the default METHODS): min-error on a
# hexagonal lattice of the same density as the pixels, resampled to them.
METHOD_OPTS_hex-hat      := --lattice hex --generator hex-hat --display centred
METHOD_OPTS_hex-quartic  := --lattice hex --generator hex-quartic --display centred

# Binaries given on the command line are used as they are; the default ones
# are brought up to date by the build target first.
SIPROJECT ?= $(BUILD)/tools/siproject
SIMETRICS ?= $(BUILD)/tools/simetrics
SIRAYS ?= $(BUILD)/tools/sirays
PREBUILT := $(filter command line environment,$(origin SIPROJECT))

# Sub-makes (cmake --build) print no "Entering directory" lines.
MAKEFLAGS += --no-print-directory
# One job at a time: POV-Ray and siproject use every core themselves, and the
# times in the summary stay comparable. Bands (TILES > 1) are meant to run
# in parallel.
ifeq ($(TILES)-$(SAMPLES)-$(filter anim anim-subframes,$(MAKECMDGOALS)),1-regular-)
.NOTPARALLEL:
endif
.DELETE_ON_ERROR:

.PHONY: all scene all-scenes setup build test install docs clean band-cuts FORCE
.DEFAULT_GOAL := all

all: scene

setup:
	@bash scripts/setup.sh

# The Python module is built with the project's .venv (pybind11, numpy) and
# put on its path: .venv/bin/python -c "import siproject" after make.
VENV_PYTHON := $(CURDIR)/.venv/bin/python
build: setup
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE=$(VENV_PYTHON) $(CMAKE_FLAGS) >/dev/null
	@cmake --build $(BUILD) -j $(JOBS)
	@site=$$($(VENV_PYTHON) -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])') && \
	  echo "$(abspath $(BUILD))/python" > "$$site/siproject-build.pth"

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

PREFIX ?= /usr/local
INSTALL_PYTHON ?= python3
install: build
	@SIS_INSTALL_PYTHON="$$(command -v $(INSTALL_PYTHON))" cmake --install $(BUILD) --prefix $(PREFIX)

clean:
	rm -rf $(BUILD) $(OUT)

# The first render row of each of the TILES bands, then the render's height.
band-cuts:
	@echo $(foreach i,$(band_indices) $(TILES),$(call band_y0,$(i)))

ifeq ($(PREBUILT),)
$(SIPROJECT): build ;
$(SIRAYS): build ;
endif

# ---- the render pipeline ------------------------------------------------------
# Goals other than these need valid sizes.
ifneq ($(filter-out setup build test clean FORCE,$(or $(MAKECMDGOALS),all)),)

RES_W := $(firstword $(subst x, ,$(RES)))
RES_H := $(or $(word 2,$(subst x, ,$(RES))),$(RES_W))
ifneq ($(shell echo '$(RES_W) $(RES_H)' | grep -Ex '[1-9][0-9]* [1-9][0-9]*'),$(RES_W) $(RES_H))
$(error RES=$(RES): expected N or WxH, positive integers)
endif
ifneq ($(words $(subst x, ,$(RES))),$(if $(findstring x,$(RES)),2,1))
$(error RES=$(RES): expected N or WxH, positive integers)
endif
ifeq ($(shell echo '$(FACTOR)' | grep -Ex '([0-9]+\.?[0-9]*|\.[0-9]+)' | awk '$$1 > 0'),)
$(error FACTOR=$(FACTOR): expected a positive number)
endif
ifneq ($(shell echo '$(TILES)' | grep -Ex '[1-9][0-9]*'),$(TILES))
$(error TILES=$(TILES): expected a positive whole number)
endif
ifeq ($(filter $(SAMPLES),regular jitter sobol adaptive),)
$(error SAMPLES=$(SAMPLES): expected regular, jitter, sobol or adaptive)
endif
# SAMPLES=adaptive (docs/design.md section 17): a sobol first pass of
# ADAPT_BASE rays per pixel (its render is make SAMPLES=sobol's at FACTOR =
# sqrt(ADAPT_BASE)), sirays refine's tiles for the budget of RAYS rays per
# pixel, and the second pass of their extra rays.
ifeq ($(SAMPLES),adaptive)
ADAPTIVE := 1
ifeq ($(shell echo '$(RAYS)' | grep -Ex '[0-9]+([.][0-9]+)?'),)
$(error SAMPLES=adaptive needs RAYS=N, the rays per output pixel over the whole frame (a number > 0), e.g. RAYS=16)
endif
ADAPT_BASE ?= $(shell awk 'BEGIN { print ($(RAYS) < 4) ? 1 : ($(RAYS) >= 64 ? 16 : 4) }')
ADAPT_FACTOR := $(shell awk 'BEGIN { b = "$(ADAPT_BASE)" + 0; s = int(sqrt(b) + 0.5); if (b >= 1 && s * s == b && "$(ADAPT_BASE)" ~ /^[0-9]+$$/) print s }')
ifeq ($(ADAPT_FACTOR),)
$(error ADAPT_BASE=$(ADAPT_BASE): the first pass's rays per pixel must be the square of a whole number (1, 4, 9, 16...): the sobol render of a whole FACTOR)
endif
ifneq ($(shell awk 'BEGIN { print ($(RAYS) >= $(ADAPT_BASE)) ? "ok" : "" }'),ok)
$(error RAYS=$(RAYS) is below the first pass's ADAPT_BASE=$(ADAPT_BASE) rays per pixel: the budget must cover the base pattern)
endif
ifneq ($(ADAPT_RAYS)$(ADAPT_SHARE),)
ifneq ($(ADAPT_RAYS),)
ifneq ($(ADAPT_SHARE),)
$(error ADAPT_RAYS and ADAPT_SHARE: give one (the refined tiles' rays per pixel, or the share of the frame refined))
endif
endif
endif
override FACTOR := $(ADAPT_FACTOR)
PATTERN := sobol
else
PATTERN := $(SAMPLES)
endif
ADAPT_TILE ?= 8
ADAPT_ESTIMATOR ?= residual
ifeq ($(filter $(RULE),auto fit variational),)
$(error RULE=$(RULE): expected auto, fit or variational)
endif
# The scattered rule of the min-error cubic methods (RULE=auto: variational
# below 4 rays per pixel, where it is the closer one).
RULE_RAYS := $(if $(ADAPTIVE),$(RAYS),$(shell awk 'BEGIN { print $(FACTOR) * $(FACTOR) }'))
SCATTERED_RULE := $(if $(filter auto,$(RULE)),$(shell awk 'BEGIN { print ($(RULE_RAYS) < 4) ? "variational" : "fit" }'),$(RULE))
# hex-hat (C0) takes the first-order functional, the others the thin plate.
rule_opts_of = $(if $(SAMPLES_TAG),$(if $(filter me-cubic me-cubic-2x2 hex-quartic hex-hat,$(1)),$(if $(filter variational,$(SCATTERED_RULE)),--rule variational$(if $(filter hex-hat,$(1)), --smoothness 1))))
ifneq ($(shell echo '$(SEED)' | grep -Ex '[0-9]+'),$(SEED))
$(error SEED=$(SEED): expected a whole number >= 0)
endif
ifneq ($(shell echo '$(MESH_RAYS)' | grep -Ex '[1-9][0-9]*'),$(MESH_RAYS))
$(error MESH_RAYS=$(MESH_RAYS): expected a positive whole number)
endif
ifeq ($(filter $(FARM),local slurm slurm-submit),)
$(error FARM=$(FARM): expected local, slurm or slurm-submit)
endif
ifneq ($(shell echo '$(FARM_CPUS)' | grep -Ex '[1-9][0-9]*'),$(FARM_CPUS))
$(error FARM_CPUS=$(FARM_CPUS): expected a positive whole number)
endif
ifneq ($(shell echo '$(POV_THREADS)' | grep -Ex '([1-9][0-9]*)?'),$(POV_THREADS))
$(error POV_THREADS=$(POV_THREADS): expected a positive whole number, or nothing for POV-Ray's default)
endif
ifneq ($(FARM),local)
ifneq ($(SAMPLES),regular)
$(error FARM=$(FARM) renders regular samples only: SAMPLES=$(SAMPLES) renders in mesh bands on this machine)
endif
endif
RES_TAG := $(if $(filter $(RES_W),$(RES_H)),$(RES_W),$(RES_W)x$(RES_H))
RENDER_W := $(shell awk 'BEGIN { printf "%d", $(RES_W) * $(FACTOR) + 0.5 }')
RENDER_H := $(shell awk 'BEGIN { printf "%d", $(RES_H) * $(FACTOR) + 0.5 }')
unknown_methods := $(strip $(foreach m,$(METHODS),$(if $(METHOD_OPTS_$(m)),,$(m))))
ifneq ($(unknown_methods),)
$(error unknown method(s) $(unknown_methods); known: box conv-tent me-tent mitchell me-cubic me-tent-2x2 me-cubic-2x2 hex-hat hex-quartic)
endif

ALL_SCENES := $(sort $(basename $(notdir $(wildcard $(SCENEDIR)/*.pov))))
ifeq ($(filter $(SCENE),$(ALL_SCENES)),)
ifneq ($(filter all scene anim anim-subframes,$(or $(MAKECMDGOALS),all)),)
$(error no scene $(SCENEDIR)/$(SCENE).pov; scenes: $(ALL_SCENES))
endif
endif

# The zone plate's frequency scales with the output width (scenes/zoneplate.pov).
POVOPTS_zoneplate = Declare=ZP_K=$(shell awk 'BEGIN { printf "%.6f", $(ZP_NYQUIST) * atan2(0, -1) * $(RES_W) }')
# The sweep (scenes/sweep.pov): the zone plate's frequency as the zone plate's,
# moving at SWEEP_V frame widths per second; SWEEP_PATTERN=bars for edges.
POVOPTS_sweep = $(POVOPTS_zoneplate) Declare=SW_V=$(SWEEP_V) Declare=SW_PATTERN=$(if $(filter bars,$(SWEEP_PATTERN)),1,0)

# Writes TEXT to the stamp FILE only when it differs, so that FILE's time
# changes only with its content. $(call stamp,FILE,TEXT)
define stamp
$(shell mkdir -p $(dir $(1)))$(file >$(1).tmp,$(2))
@if cmp -s $(1).tmp $(1); then rm -f $(1).tmp; else mv -f $(1).tmp $(1); fi
endef

# SAMPLES other than regular: the pattern's tag in the render's and the
# results' names; the results go to $(OUT)/SCENE-SAMPLES-sSEED.
SAMPLES_TAG := $(if $(filter regular,$(PATTERN)),,-$(PATTERN)-s$(SEED))
dir_of = $(OUT)/$(1)$(if $(ADAPTIVE),-adaptive-r$(RAYS)-s$(SEED),$(SAMPLES_TAG))
render_of = $(OUT)/render/$(1)-$(RES_TAG)-f$(FACTOR)$(SAMPLES_TAG).exr
stats_of = $(OUT)/render/$(1)-$(RES_TAG)-f$(FACTOR)$(SAMPLES_TAG).stats
render_stamp_of = $(OUT)/render/.$(1)-$(RES_TAG)-f$(FACTOR)$(SAMPLES_TAG).cmd
render_opts_of = $(strip $(if $(POV_THREADS),+WT$(POV_THREADS)) $(POVOPTS_$(1)) $(POVOPTS))
# Row bands: band I of TILES starts at the row `siproject --band-cuts H,TILES`
# prints, a whole number of the engine's bands of BAND_ROWS rows (sis/bands.h,
# kBandRows), so that each band's partial (siproject --partial) merges to the
# single render's bits; a render of fewer such bands than TILES is cut
# evenly, [I H / TILES, (I + 1) H / TILES) (read as one image with --bands).
BAND_ROWS := 256
band_indices := $(shell seq 0 $$(( $(TILES) - 1 )))
band_of = $(OUT)/render/$(1)-$(RES_TAG)-f$(FACTOR)-band$(2)of$(TILES).exr
engine_bands := $(shell echo $$(( ( $(RENDER_H) + $(BAND_ROWS) - 1 ) / $(BAND_ROWS) )))
band_y0 = $(shell i=$$(( $(1) )); \
  if [ $$i -ge $(TILES) ]; then echo $(RENDER_H); \
  elif [ $(engine_bands) -ge $(TILES) ]; then echo $$(( $(BAND_ROWS) * ( i * $(engine_bands) / $(TILES) ) )); \
  else echo $$(( i * $(RENDER_H) / $(TILES) )); fi)
inputs_of = $(if $(filter 1,$(TILES))$(SAMPLES_TAG),$(call render_of,$(1)),$(foreach i,$(band_indices),$(call band_of,$(1),$(i))))
method_cmd_of = $(strip $(SIPROJECT) $(call inputs_of,$(1)) $(if $(filter 1,$(TILES))$(SAMPLES_TAG),,--bands) $(if $(ADAPTIVE),--refined $(call extra_of,$(1))) --size $(RES_W)x$(RES_H) $(METHOD_OPTS_$(2)) $(call rule_opts_of,$(2)) $(SIFLAGS))
# SAMPLES=adaptive: the refinement (sirays refine), every tile's estimate,
# the second pass's render (the extra rays) and its statistics.
adapt_name_of = $(OUT)/render/$(1)-$(RES_TAG)-adaptive-r$(RAYS)-s$(SEED)
refine_of = $(call adapt_name_of,$(1)).refine.txt
estimates_of = $(call adapt_name_of,$(1)).estimates.exr
extra_of = $(call adapt_name_of,$(1)).exr
extra_stats_of = $(call adapt_name_of,$(1)).stats
adapt_stamp_of = $(dir $(call adapt_name_of,$(1))).$(notdir $(call adapt_name_of,$(1))).cmd
REFINE_OPTS = --rays $(RAYS) $(if $(ADAPT_RAYS),--refine-rays $(ADAPT_RAYS)) $(if $(ADAPT_SHARE),--share $(ADAPT_SHARE)) --tile $(ADAPT_TILE) --estimator $(ADAPT_ESTIMATOR)
summary_of = $(call dir_of,$(1))/summary.txt

# $(call band_rules,SCENE,I,Y0,Y1): band I, render rows [Y0, Y1)
# (scripts/render_band.sh: POV-Ray's +SR/+ER, cropped by oiiotool).
define band_rules
$(call band_of,$(1),$(2)): $(SCENEDIR)/$(1).pov scenes/povray.ini $(call render_stamp_of,$(1)) | $(if $(PREBUILT),,setup)
	@printf 'render   %-10s band %s of %s: rows %s to %s of %s x %s\n' $(1) $(2) $(TILES) $(3) $$$$(( $(4) - 1 )) $(RENDER_W) $(RENDER_H)
	@bash scripts/render_band.sh $$< $$@ $(RENDER_W) $(RENDER_H) $(3) $(4) $(if $(POV_THREADS),,+WT1) $(call render_opts_of,$(1))
endef

# Mesh bands (SAMPLES not regular): band I of MESH_BANDS holds the pattern's
# grid rows [I MESH_ROWS, (I + 1) MESH_ROWS), at most MESH_RAYS rays. Its
# scene (sirays mesh: the scene with a mesh camera) is written, rendered and
# removed in one recipe, so the disk holds only the scenes of the bands in
# flight. POV-Ray 3.7.0 repeats the first face row (FS#254, fixed in 3.7.1):
# there each band renders one row more and sirays assemble --row-bug drops it.
POVRAY_ROW_BUG := $(if $(SAMPLES_TAG),$(shell povray --version 2>&1 | grep -q 'POV-Ray 3\.7\.0' && echo 1))
MESH_ROWS := $(shell echo $$(( $(MESH_RAYS) / $(RENDER_W) > 0 ? $(MESH_RAYS) / $(RENDER_W) : 1 )))
MESH_BANDS := $(shell echo $$(( ( $(RENDER_H) + $(MESH_ROWS) - 1 ) / $(MESH_ROWS) )))
mesh_indices := $(shell seq 0 $$(( $(MESH_BANDS) - 1 )))
mesh_band_of = $(OUT)/render/$(1)-$(RES_TAG)-f$(FACTOR)$(SAMPLES_TAG)-mesh$(2)of$(MESH_BANDS).exr
mesh_stats_of = $(OUT)/render/$(1)-$(RES_TAG)-f$(FACTOR)$(SAMPLES_TAG)-mesh$(2)of$(MESH_BANDS).stats
mesh_y1 = $(shell echo $$(( ( $(1) + 1 ) * $(MESH_ROWS) < $(RENDER_H) ? ( $(1) + 1 ) * $(MESH_ROWS) : $(RENDER_H) )))
PATTERN_OPTS := --pattern $(PATTERN) --seed $(SEED) --size $(RES_W)x$(RES_H) --factor $(FACTOR)

# $(call mesh_rules,SCENE,I,Y0,Y1)
define mesh_rules
$(call mesh_band_of,$(1),$(2)) $(call mesh_stats_of,$(1),$(2)) &: $(SCENEDIR)/$(1).pov scenes/povray.ini $(call render_stamp_of,$(1)) $(SIRAYS) | $(if $(PREBUILT),,setup)
	@printf 'render   %-10s %s rays, band %s of %s: rows %s to %s of %s x %s\n' $(1) $(PATTERN) $(2) $(MESH_BANDS) $(3) $$$$(( $(4) - 1 )) $(RENDER_W) $(RENDER_H)
	@b=$(call mesh_band_of,$(1),$(2)); t=$$$$(dirname $$$$b)/.$$$$(basename $$$$b).tmp; \
	t0=$$$$(date +%s.%N) && \
	$(SIRAYS) mesh $$< -o $$$$t.pov $(PATTERN_OPTS) --rows $(3):$(4) && \
	t1=$$$$(date +%s.%N) && bytes=$$$$(stat -c %s $$$$t.pov) && \
	RENDER_STATS=$$$$t.stats RENDER_MESH_CAMERA=1 bash scripts/render.sh $$$$t.pov $$$$t.exr $(RENDER_W) $$$$(( $(4) - $(3) $(if $(POVRAY_ROW_BUG),+ 1) )) $(call render_opts_of,$(1)) && \
	awk -v a=$$$$t0 -v b=$$$$t1 -v n=$$$$bytes -v r=$$$$(( $(RENDER_W) * ( $(4) - $(3) ) )) \
	  'BEGIN { printf "rays %d\nmesh_s %.3f\nmesh_bytes %d\n", r, b - a, n }' >> $$$$t.stats && \
	rm -f $$$$t.pov && mv -f $$$$t.stats $(call mesh_stats_of,$(1),$(2)) && mv -f $$$$t.exr $$$$b || \
	{ rc=$$$$?; rm -f $$$$t.pov $$$$t.exr $$$$t.stats; exit $$$$rc; }
endef

# $(call scene_rules,SCENE)
define scene_rules
$(call render_stamp_of,$(1)): FORCE
	$$(call stamp,$$@,$(RENDER_W) $(RENDER_H) $(call render_opts_of,$(1)))

ifeq ($(SAMPLES_TAG),)
$(call render_of,$(1)) $(call stats_of,$(1)) &: $(SCENEDIR)/$(1).pov scenes/povray.ini $(call render_stamp_of,$(1)) | $(if $(PREBUILT),,setup)
	@printf 'render   %-10s %s x %s (%s x %s, factor %s) -> %s\n' $(1) $(RENDER_W) $(RENDER_H) $(RES_W) $(RES_H) $(FACTOR) $(call render_of,$(1))
	@RENDER_STATS=$(call stats_of,$(1)) RENDER_REPEATS=$(RENDER_REPEATS) \
	  bash scripts/render.sh $$< $(call render_of,$(1)) $(RENDER_W) $(RENDER_H) $(call render_opts_of,$(1))
else
# The render's statistics: the sums over its bands.
$(call render_of,$(1)) $(call stats_of,$(1)) &: $(foreach i,$(mesh_indices),$(call mesh_band_of,$(1),$(i))) $(SIRAYS)
	@printf 'assemble %-10s %s x %s %s rays (seed %s, %s bands) -> %s\n' $(1) $(RENDER_W) $(RENDER_H) $(PATTERN) $(SEED) $(MESH_BANDS) $(call render_of,$(1))
	@t=$(dir $(call stats_of,$(1))).$(notdir $(call stats_of,$(1))).tmp; \
	awk '$$$$1 != "wall_runs" { sum[$$$$1] += $$$$2; if (!($$$$1 in seen)) { seen[$$$$1] = 1; order[++n] = $$$$1 } } \
	  END { for (i = 1; i <= n; i++) print order[i], sum[order[i]]; print "bands", $(MESH_BANDS) }' \
	  $(foreach i,$(mesh_indices),$(call mesh_stats_of,$(1),$(i))) > $$$$t && \
	$(SIRAYS) assemble $(foreach i,$(mesh_indices),$(call mesh_band_of,$(1),$(i))) -o $(call render_of,$(1)) $(PATTERN_OPTS) $(if $(POVRAY_ROW_BUG),--row-bug) && \
	mv -f $$$$t $(call stats_of,$(1)) || { rc=$$$$?; rm -f $$$$t; exit $$$$rc; }
endif

$(call dir_of,$(1))/.summary.cmd: FORCE
	$$(call stamp,$$@,$(METHODS) | $(CUTOFFS) | $(call render_of,$(1)))

$(call dir_of,$(1))/summary.txt $(call dir_of,$(1))/summary.csv &: $(foreach m,$(METHODS),$(call dir_of,$(1))/$(m).exr) scripts/summary.sh $(wildcard $(SIMETRICS)) $(call dir_of,$(1))/.summary.cmd
	@bash scripts/summary.sh --dir $(call dir_of,$(1)) --render $(call render_of,$(1)) \
	  --sizes '$(RES_W) $(RES_H) $(RENDER_W) $(RENDER_H)' --simetrics '$(SIMETRICS)' --cutoffs '$(CUTOFFS)' $(METHODS)

# The page of the scene's images side by side, two enlarged crops each, and the summary.
$(call dir_of,$(1))/index.html: $(foreach m,$(METHODS),$(call dir_of,$(1))/$(m).png) $(if $(ADAPTIVE),$(call dir_of,$(1))/rays.png) $(call dir_of,$(1))/summary.txt scripts/scene_page.py
	@$$(PYTHON) scripts/scene_page.py $(call dir_of,$(1)) $(foreach m,$(METHODS),'$(m)=$(strip $(METHOD_OPTS_$(m)) $(call rule_opts_of,$(m)))')
endef

# $(call adaptive_rules,SCENE): the refinement from the first pass, then
# the second pass: the extra rays through the mesh camera in bands of at
# most MESH_RAYS rays (one POV-Ray process each: one for any refinement
# under MESH_RAYS rays), assembled with the refinement in their metadata;
# with no tile refined, no ray is traced and the file holds none. The
# statistics: the bands' sums, with refine_s (sirays refine's wall time).
# The picture of where the rays went: rays.png beside the images.
define adaptive_rules
$(call adapt_stamp_of,$(1)): FORCE
	$$(call stamp,$$@,$(REFINE_OPTS))

$(call refine_of,$(1)) $(call estimates_of,$(1)) &: $(call render_of,$(1)) $(SIRAYS) $(call adapt_stamp_of,$(1))
	@printf 'refine   %-10s %s rays per pixel from %s (%s)\n' $(1) $(RAYS) $(call render_of,$(1)) '$(REFINE_OPTS)'
	@t0=$$$$(date +%s.%N); $(SIRAYS) refine $(call render_of,$(1)) -o $(call refine_of,$(1)) --estimates $(call estimates_of,$(1)) $(REFINE_OPTS) && \
	awk -v a=$$$$t0 -v b=$$$$(date +%s.%N) 'BEGIN { printf "refine_s %.3f\n", b - a }' > $(call refine_of,$(1)).seconds

$(call extra_of,$(1)) $(call extra_stats_of,$(1)) &: $(call refine_of,$(1)) $(SCENEDIR)/$(1).pov scenes/povray.ini $(call render_stamp_of,$(1)) $(SIRAYS) | $(if $(PREBUILT),,setup)
	@set -e; r=$(call refine_of,$(1)); o=$(call extra_of,$(1)); t=$$$$(dirname $$$$o)/.$$$$(basename $$$$o).tmp; \
	trap 'rm -f $$$$t-*' EXIT; set -- $$$$($(SIRAYS) grid --refinement $$$$r); gw=$$$$1; gh=$$$$2; \
	rows=$$$$(( gw > 0 && $(MESH_RAYS) / gw > 0 ? $(MESH_RAYS) / gw : 1 )); y=0; bands=; : > $$$$t-all.stats; \
	printf 'render   %-10s the second pass: %s x %s extra rays, %s band(s)\n' $(1) $$$$gw $$$$gh $$$$(( gh > 0 ? ( gh + rows - 1 ) / rows : 0 )); \
	while [ $$$$y -lt $$$$gh ]; do \
	  y1=$$$$(( y + rows < gh ? y + rows : gh )); \
	  $(SIRAYS) mesh $(SCENEDIR)/$(1).pov -o $$$$t-$$$$y.pov --refinement $$$$r --rows $$$$y:$$$$y1; \
	  RENDER_STATS=$$$$t-$$$$y.stats RENDER_MESH_CAMERA=1 bash scripts/render.sh $$$$t-$$$$y.pov $$$$t-$$$$y.exr $$$$gw $$$$(( y1 - y $(if $(POVRAY_ROW_BUG),+ 1) )) $(call render_opts_of,$(1)); \
	  rm -f $$$$t-$$$$y.pov; cat $$$$t-$$$$y.stats >> $$$$t-all.stats; bands="$$$$bands $$$$t-$$$$y.exr"; y=$$$$y1; \
	done; \
	$(SIRAYS) assemble $$$$bands -o $$$$t-out.exr --refinement $$$$r $(if $(POVRAY_ROW_BUG),--row-bug); \
	awk '$$$$1 != "wall_runs" { sum[$$$$1] += $$$$2; if (!($$$$1 in seen)) { seen[$$$$1] = 1; order[++n] = $$$$1 } } \
	  END { for (i = 1; i <= n; i++) print order[i], sum[order[i]] }' $$$$t-all.stats $$$$r.seconds > $$$$t-sum.stats; \
	echo "extra_rays $$$$(( gw * gh ))" >> $$$$t-sum.stats; \
	mv -f $$$$t-sum.stats $(call extra_stats_of,$(1)); mv -f $$$$t-out.exr $$$$o

$(call dir_of,$(1))/rays.png: $(call refine_of,$(1)) $(call extra_stats_of,$(1)) $(call dir_of,$(1))/$(firstword $(METHODS)).png scripts/adaptive_picture.py
	@$$(PYTHON) scripts/adaptive_picture.py --refinement $(call refine_of,$(1)) --image $(call dir_of,$(1))/$(firstword $(METHODS)).png \
	  --stats $(call extra_stats_of,$(1)) --out $$@
endef

# $(call method_rules,SCENE,METHOD): METHOD.exr (float, for the measures), .png (8-bit sRGB) and
# .log (siproject -v: the stage times) from one render; written to temporary
# names and renamed when both runs succeeded.
define method_rules
$(call dir_of,$(1))/.$(2).cmd: FORCE
	$$(call stamp,$$@,$(call method_cmd_of,$(1),$(2)))

$(call dir_of,$(1))/$(2).exr $(call dir_of,$(1))/$(2).png $(call dir_of,$(1))/$(2).log &: $(call inputs_of,$(1)) $(if $(ADAPTIVE),$(call extra_of,$(1))) $(SIPROJECT) $(call dir_of,$(1))/.$(2).cmd
	@t=$(call dir_of,$(1))/.$(2).tmp; \
	$(call method_cmd_of,$(1),$(2)) -o $$$$t.exr -d float -v 2>$$$$t.log && \
	$(call method_cmd_of,$(1),$(2)) -o $$$$t.png -q || \
	{ rc=$$$$?; cat $$$$t.log >&2; rm -f $$$$t.exr $$$$t.png $$$$t.log; exit $$$$rc; }; \
	mv -f $$$$t.exr $(call dir_of,$(1))/$(2).exr && mv -f $$$$t.png $(call dir_of,$(1))/$(2).png && mv -f $$$$t.log $(call dir_of,$(1))/$(2).log && \
	printf 'project  %-10s %-13s %s s\n' $(1) $(2) "$$$$(sed -n 's/.*total \([0-9.]*\) s.*/\1/p' $(call dir_of,$(1))/$(2).log)"
endef

$(foreach s,$(ALL_SCENES),$(foreach i,$(band_indices),$(eval $(call band_rules,$(s),$(i),$(call band_y0,$(i)),$(call band_y0,$(i) + 1)))))
$(if $(SAMPLES_TAG),$(foreach s,$(ALL_SCENES),$(foreach i,$(mesh_indices),$(eval $(call mesh_rules,$(s),$(i),$(shell echo $$(( $(i) * $(MESH_ROWS) ))),$(call mesh_y1,$(i)))))))
# FARM=slurm, slurm-submit: the bands render on a Slurm cluster
# (scripts/farm/slurm.sh; docs/pipeline.md "On a Slurm cluster"). Band job I
# renders rows [Y_I, Y_I+1) on its node and writes each method's partial of
# them (siproject --partial: the method's options but --display, SIFLAGS)
# to $(OUT)/farm/SCENE-RES-fFACTOR-tilesK/METHOD-bandIofK.exr; the merge job
# (siproject --merge with the method's --display) writes METHOD.exr, .png and
# .log as the local rules do. The cuts are whole engine bands, so the images
# are the single render's bits.
ifneq ($(FARM),local)
ifneq ($(filter all scene all-scenes,$(or $(MAKECMDGOALS),all)),)
ifeq ($(shell [ $(engine_bands) -ge $(TILES) ] && echo ok),)
$(error FARM=$(FARM) TILES=$(TILES): the render's $(RENDER_H) rows make $(engine_bands) bands of $(BAND_ROWS), fewer than TILES; each band job needs whole bands (TILES at most $(engine_bands), or a larger RES or FACTOR))
endif
endif
endif
farm_name_of = $(1)-$(RES_TAG)-f$(FACTOR)
farm_dir_of = $(OUT)/farm/$(call farm_name_of,$(1))-tiles$(TILES)
display_eq_of = $(subst --display ,--display=,$(METHOD_OPTS_$(1)))
partial_opts_of = --size $(RES_W)x$(RES_H) $(filter-out --display=%,$(call display_eq_of,$(1))) $(SIFLAGS)
display_opts_of = $(filter --display=%,$(call display_eq_of,$(1)))
farm_outputs_of = $(foreach m,$(METHODS),$(call dir_of,$(1))/$(m).exr $(call dir_of,$(1))/$(m).png $(call dir_of,$(1))/$(m).log)
band_cuts = $(foreach i,$(band_indices) $(TILES),$(call band_y0,$(i)))

# $(call farm_rules,SCENE)
define farm_rules
$(foreach m,$(METHODS),$(call dir_of,$(1))/.$(m).cmd): FORCE
	$$(call stamp,$$@,farm $(TILES) | $$(call partial_opts_of,$$(patsubst .%.cmd,%,$$(notdir $$@))) | $$(call display_opts_of,$$(patsubst .%.cmd,%,$$(notdir $$@))))

$(call farm_outputs_of,$(1)) &: $(SCENEDIR)/$(1).pov scenes/povray.ini $(call render_stamp_of,$(1)) $(SIPROJECT) $(foreach m,$(METHODS),$(call dir_of,$(1))/.$(m).cmd) \
  scripts/render.sh scripts/render_band.sh scripts/farm/band.sh scripts/farm/merge.sh scripts/farm/slurm.sh | $(if $(PREBUILT),,setup)
	@printf 'farm     %-10s %s bands of %s x %s on Slurm\n' $(1) $(TILES) $(RENDER_W) $(RENDER_H)
	@bash scripts/farm/slurm.sh --name $(call farm_name_of,$(1)) --tiles $(TILES) --methods '$(METHODS)' \
	  --partials $(call farm_dir_of,$(1)) --logs $(call farm_dir_of,$(1))/logs --outputs '$(call farm_outputs_of,$(1))' \
	  --cpus $(FARM_CPUS) --slurm-args '$(SLURM_ARGS)' $(if $(filter slurm-submit,$(FARM)),--submit-only) \
	  --scene $(SCENEDIR)/$(1).pov --render $(RENDER_W)x$(RENDER_H) --cuts '$(band_cuts)' \
	  --partials $(call farm_dir_of,$(1)) --siproject $(SIPROJECT) --povopts '$(call render_opts_of,$(1))' \
	  $(foreach m,$(METHODS),'$(m)=$(call partial_opts_of,$(m))') \
	  --merge --partials $(call farm_dir_of,$(1)) --tiles $(TILES) --out $(call dir_of,$(1)) --siproject $(SIPROJECT) \
	  $(foreach m,$(METHODS),'$(m)=$(call display_opts_of,$(m))')
endef

ifeq ($(FARM),local)
$(foreach s,$(ALL_SCENES),$(eval $(call scene_rules,$(s)))$(foreach m,$(METHODS),$(eval $(call method_rules,$(s),$(m)))))
$(if $(ADAPTIVE),$(foreach s,$(ALL_SCENES),$(eval $(call adaptive_rules,$(s)))))
else
$(foreach s,$(ALL_SCENES),$(eval $(call scene_rules,$(s)))$(eval $(call farm_rules,$(s))))
endif

# The render alone, as a make target: make render SCENE=... SAMPLES=...
.PHONY: render
render: $(call render_of,$(SCENE)) $(if $(ADAPTIVE),$(call extra_of,$(SCENE)))

# Without SIPROJECT given, set up and build first (the build brings the
# default binaries up to date; images depend on them).
ifeq ($(FARM),slurm-submit)
scene: $(if $(PREBUILT),,build) $(call farm_outputs_of,$(SCENE))
	@echo "farm: once the merge job has ended, make FARM=slurm with the same variables writes the summary from its images"
else
scene: $(if $(PREBUILT),,build) $(call summary_of,$(SCENE)) $(call dir_of,$(SCENE))/index.html
	@echo
	@cat $(call summary_of,$(SCENE))
	@echo "The images side by side: $(call dir_of,$(SCENE))/index.html"
endif

all-scenes: $(if $(PREBUILT),,build) $(foreach s,$(ALL_SCENES),$(call summary_of,$(s)) $(call dir_of,$(s))/index.html)
	@for f in $(filter %/summary.txt,$^); do echo; cat "$$f"; done


# ---- anim: sub-frames, space-time frames and videos (docs/pipeline.md) -------
# make anim SCENE=carousel FRAMES=48 SUBFRAMES=4: SUBFRAMES sub-frames per
# rendered frame at RENDER_FPS (scripts/anim_times.py: the centres of equal
# parts of each frame interval, or jittered with TIME_JITTER=SEED), each its
# own make target rendered through POV-Ray's Clock (seconds) and tagged with
# its time (sis:time, by oiiotool), so make -j and a make-driven farm render
# them in parallel; then the frames at FPS by siproject --fps twice: the
# space-time projection (ANIM_METHOD's spatial options, TIME_DEGREE,
# TIME_MODEL, SHUTTER, SHUTTER_CURVE) and, when FPS is RENDER_FPS, the
# sub-frame average within the shutter (the conventional box: what
# averaging sub-frames gives); each
# encoded by ffmpeg as an MP4 (H.264) and an animated WebP, shown side by
# side in index.html. Files in $(ANIM_DIR):
#   sub.NNNN.exr                  the sub-frames (half, linear; sis:time)
#   spacetime-FPSfps/frame.NNNN.png, average-FPSfps/...   the frames
#   spacetime-FPSfps.mp4, .webp, average-FPSfps.mp4, .webp, index.html
FRAMES ?= 24
SUBFRAMES ?= 4
RENDER_FPS ?= 24
FPS ?= $(RENDER_FPS)
SHUTTER ?= 180
SHUTTER_CURVE ?= box
TIME_DEGREE ?= 3
TIME_MODEL ?= cubic
TIME_JITTER ?=
ANIM_METHOD ?= me-cubic
SWEEP_V ?= 0.25
SWEEP_PATTERN ?= zoneplate
ANIM_GOALS := $(filter anim anim-subframes,$(MAKECMDGOALS))
ifneq ($(ANIM_GOALS),)
ifneq ($(shell echo '$(FRAMES) $(SUBFRAMES)' | grep -Ex '[1-9][0-9]* [1-9][0-9]*'),$(FRAMES) $(SUBFRAMES))
$(error FRAMES=$(FRAMES) SUBFRAMES=$(SUBFRAMES): expected positive whole numbers)
endif
ifeq ($(shell echo '$(RENDER_FPS) $(FPS)' | grep -Ex '([0-9]+\.?[0-9]*|\.[0-9]+) ([0-9]+\.?[0-9]*|\.[0-9]+)' | awk '$$1 > 0 && $$2 > 0'),)
$(error RENDER_FPS=$(RENDER_FPS) FPS=$(FPS): expected positive numbers)
endif
ifneq ($(shell echo '$(TIME_JITTER)' | grep -Ex '[0-9]*'),$(TIME_JITTER))
$(error TIME_JITTER=$(TIME_JITTER): expected a whole number >= 0 (a seed), or empty for regular times)
endif
ifeq ($(filter $(ANIM_METHOD),me-tent me-cubic me-tent-2x2 me-cubic-2x2),)
$(error ANIM_METHOD=$(ANIM_METHOD): the space-time projection's spatial method, one of me-tent me-cubic me-tent-2x2 me-cubic-2x2 (a conventional method would make it the sub-frame average))
endif
ifeq ($(filter $(SWEEP_PATTERN),zoneplate bars),)
$(error SWEEP_PATTERN=$(SWEEP_PATTERN): expected zoneplate or bars)
endif
ifneq ($(SAMPLES)-$(TILES)-$(FARM),regular-1-local)
$(error make anim renders whole regular sub-frames on this machine: SAMPLES=$(SAMPLES) TILES=$(TILES) FARM=$(FARM) are not taken (regular, 1, local))
endif
ifeq ($(shell echo '$(SHUTTER)' | grep -Ex '([0-9]+\.?[0-9]*|\.[0-9]+)(:-?([0-9]+\.?[0-9]*|\.[0-9]+))?' | awk -F: '$$1 > 0 && $$1 <= 360'),)
$(error SHUTTER=$(SHUTTER): expected ANGLE[:PHASE] in degrees, the angle above 0 and at most 360)
endif
ifneq ($(words $(ANIM_METHOD) $(TIME_DEGREE) $(TIME_MODEL) $(SHUTTER) $(SHUTTER_CURVE) $(SWEEP_V)),6)
$(error make anim: ANIM_METHOD, TIME_DEGREE, TIME_MODEL, SHUTTER, SHUTTER_CURVE and SWEEP_V take one word each (a SHUTTER_CURVE path without blanks))
endif
ifeq ($(filter $(SHUTTER_CURVE),box tent cubic)$(shell test -f '$(SHUTTER_CURVE)' && echo file),)
$(error SHUTTER_CURVE=$(SHUTTER_CURVE): expected box, tent, cubic or a table file that exists)
endif
ifeq ($(filter $(TIME_DEGREE),0 1 2 3),)
$(error TIME_DEGREE=$(TIME_DEGREE): expected 0, 1, 2 or 3)
endif
ifeq ($(filter $(TIME_MODEL),hold linear cubic),)
$(error TIME_MODEL=$(TIME_MODEL): expected hold, linear or cubic)
endif
ifeq ($(shell echo '$(SWEEP_V)' | grep -Ex -- '-?([0-9]+\.?[0-9]*|\.[0-9]+)'),)
$(error SWEEP_V=$(SWEEP_V): expected a number (frame widths per second))
endif
ifeq ($(shell grep -qiw clock $(SCENEDIR)/$(SCENE).pov 2>/dev/null && echo yes),)
$(warning make anim: $(SCENEDIR)/$(SCENE).pov does not read the clock: every sub-frame is the same image)
endif
endif
# Rates as numbers (24, 24.0 and 24.00 are one rate: one folder, one name)
override RENDER_FPS := $(shell awk 'BEGIN { printf "%.12g", $(RENDER_FPS) }' 2>/dev/null)
override FPS := $(shell awk 'BEGIN { printf "%.12g", $(FPS) }' 2>/dev/null)
ANIM_DIR := $(OUT)/anim/$(SCENE)-$(RES_TAG)-f$(FACTOR)-$(RENDER_FPS)fps-k$(SUBFRAMES)$(if $(TIME_JITTER),-j$(TIME_JITTER))
ANIM_COUNT := $(shell echo $$(( $(FRAMES) * $(SUBFRAMES) )))
# NNNN:TIME, one word per sub-frame
ANIM_PAIRS := $(if $(ANIM_GOALS),$(shell python3 scripts/anim_times.py --frames $(FRAMES) \
  --subframes $(SUBFRAMES) --fps $(RENDER_FPS) $(if $(TIME_JITTER),--jitter $(TIME_JITTER)) --pairs))
ifneq ($(ANIM_GOALS),)
ifneq ($(words $(ANIM_PAIRS)),$(ANIM_COUNT))
$(error make anim: scripts/anim_times.py gave $(words $(ANIM_PAIRS)) sub-frame times, not $(ANIM_COUNT) (is python3 there?))
endif
endif
sub_of = $(ANIM_DIR)/sub.$(1).exr
anim_subs := $(foreach p,$(ANIM_PAIRS),$(call sub_of,$(firstword $(subst :, ,$(p)))))
ANIM_TIME_OPTS := --fps $(FPS) --shutter $(SHUTTER) --shutter-curve $(SHUTTER_CURVE)
anim_cmd_spacetime = $(METHOD_OPTS_$(ANIM_METHOD)) $(ANIM_TIME_OPTS) --time-degree $(TIME_DEGREE) --time-model $(TIME_MODEL) $(SIFLAGS)
anim_cmd_average = $(METHOD_OPTS_box) $(ANIM_TIME_OPTS) $(SIFLAGS)

# $(call sub_rules,N,TIME): sub-frame N, rendered at Clock=TIME; oiiotool
# records the time as a string (its float type keeps 7 digits only).
define sub_rules
$(call sub_of,$(1)): $(SCENEDIR)/$(SCENE).pov scenes/povray.ini $(call render_stamp_of,$(SCENE)) | $(if $(PREBUILT),,setup)
	@printf 'render   %-10s sub-frame %s of %s at t = %s s\n' $(SCENE) $(1) $(ANIM_COUNT) $(2)
	@t=$(ANIM_DIR)/.sub.$(1).tmp; trap 'rm -f $$$$t-pov.exr $$$$t.exr; exit 130' INT HUP; \
	trap 'rm -f $$$$t-pov.exr $$$$t.exr; exit 143' TERM; \
	bash scripts/render.sh $$< $$$$t-pov.exr $(RENDER_W) $(RENDER_H) $(call render_opts_of,$(SCENE)) Clock=$(2) && \
	oiiotool $$$$t-pov.exr --attrib:type=string sis:time $(2) -o $$$$t.exr && \
	rm -f $$$$t-pov.exr && mv -f $$$$t.exr $$@ || { rc=$$$$?; rm -f $$$$t-pov.exr $$$$t.exr; exit $$$$rc; }
endef
$(foreach p,$(ANIM_PAIRS),$(eval $(call sub_rules,$(firstword $(subst :, ,$(p))),$(lastword $(subst :, ,$(p))))))

# $(call anim_rules,KIND): KIND-FPSfps/ frames, .mp4 and .webp, made in
# temporary names (removed on failure and on INT, TERM, HUP) and moved into
# place when all are written. The MP4 is BT.709 (its matrix, primaries and
# the sRGB transfer of the PNG frames), tagged so.
define anim_rules
$(ANIM_DIR)/.$(1)-$(FPS)fps.cmd: FORCE
	$$(call stamp,$$@,$(anim_cmd_$(1)) | $(ANIM_COUNT) sub-frames)

$(ANIM_DIR)/$(1)-$(FPS)fps.mp4 $(ANIM_DIR)/$(1)-$(FPS)fps.webp &: $(anim_subs) $(SIPROJECT) $(ANIM_DIR)/.$(1)-$(FPS)fps.cmd $(wildcard $(SHUTTER_CURVE))
	@d=$(ANIM_DIR)/$(1)-$(FPS)fps; t=$(ANIM_DIR)/.$(1)-$(FPS)fps.tmp; \
	clean() { { [ ! -e $$$$t.old ] || [ -e $$$$d ] || mv -f $$$$t.old $$$$d; }; rm -rf $$$$t $$$$t.mp4 $$$$t.webp $$$$t.old; }; \
	trap 'clean; exit 130' INT HUP; trap 'clean; exit 143' TERM; \
	clean; mkdir -p $$$$t && \
	$(SIPROJECT) $(anim_subs) --size $(RES_W)x$(RES_H) $(anim_cmd_$(1)) -o $$$$t/frame.#.png -q && \
	first=$$$$(ls $$$$t | head -1 | sed 's/frame\.0*\([0-9][0-9]*\)\.png/\1/') && \
	ffmpeg -nostdin -y -loglevel error -framerate $(FPS) -start_number $$$$first -i $$$$t/frame.%04d.png \
	  -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2,scale=out_color_matrix=bt709:out_range=tv,format=yuv420p' \
	  -colorspace bt709 -color_primaries bt709 -color_trc iec61966-2-1 -color_range tv \
	  -c:v libx264 -crf 16 -movflags +faststart $$$$t.mp4 && \
	ffmpeg -nostdin -y -loglevel error -framerate $(FPS) -start_number $$$$first -i $$$$t/frame.%04d.png \
	  -c:v libwebp_anim -lossless 1 -loop 0 $$$$t.webp && \
	{ [ ! -e $$$$d ] || mv -f $$$$d $$$$t.old; } && mv -f $$$$t $$$$d && rm -rf $$$$t.old && \
	mv -f $$$$t.mp4 $$$$d.mp4 && mv -f $$$$t.webp $$$$d.webp || \
	{ rc=$$$$?; clean; exit $$$$rc; }
	@printf 'frames   %-10s %-9s %s frames at %s fps -> %s\n' $(SCENE) $(1) $$$$(ls $(ANIM_DIR)/$(1)-$(FPS)fps | wc -l) $(FPS) $(ANIM_DIR)/$(1)-$(FPS)fps.mp4
endef
# The average only at the rendered rate and where every frame's shutter
# holds a sub-frame (scripts/anim_times.py --average-ok checks the frames
# siproject forms, on the times as written); otherwise a frame may have none
# to average (the frame-rate conversion is the space-time projection's).
ANIM_AVERAGE := $(and $(ANIM_GOALS),$(filter $(FPS),$(RENDER_FPS)),$(shell python3 scripts/anim_times.py \
  --frames $(FRAMES) --subframes $(SUBFRAMES) --fps $(RENDER_FPS) $(if $(TIME_JITTER),--jitter $(TIME_JITTER)) \
  --average-ok $(SHUTTER) --out-fps $(FPS)))
ANIM_KINDS := spacetime $(if $(ANIM_AVERAGE),average)
$(foreach k,$(ANIM_KINDS),$(eval $(call anim_rules,$(k))))

$(ANIM_DIR)/index-$(FPS)fps.html: $(foreach k,$(ANIM_KINDS),$(ANIM_DIR)/$(k)-$(FPS)fps.webp) scripts/anim_page.py
	@$(PYTHON) scripts/anim_page.py --dir $(ANIM_DIR) --fps $(FPS) --render-fps $(RENDER_FPS) --scene $(SCENE) \
	  --subframes $(ANIM_COUNT) \
	  --spacetime '$(anim_cmd_spacetime)' $(if $(filter average,$(ANIM_KINDS)),--average '$(anim_cmd_average)') -o $@

.PHONY: anim anim-subframes
anim-subframes: $(anim_subs)
anim: $(if $(PREBUILT),,build) $(ANIM_DIR)/index-$(FPS)fps.html
	@echo "anim: $(ANIM_DIR)/index-$(FPS)fps.html (videos: $(foreach k,$(ANIM_KINDS),$(ANIM_DIR)/$(k)-$(FPS)fps.mp4))"

endif

FORCE:

# ---- stability: where the methods fail (scripts/stability.py) -----------------
# make stability [QUICK=1]: out/report/stability/index.html, charts, JSON, CSV;
# renders: make render targets in $(OUT)/stability-render/{quick,full}.
.PHONY: stability
stability: $(if $(PREBUILT),,build)
	@$(PYTHON) scripts/stability.py --build $(BUILD) --out $(OUT)/report/stability $(if $(QUICK),--quick)

# ==== comparison: accuracy against speed (scripts/compare.py) =================
# make compare [QUICK=1]: every scene and method at several factors against a
# reference render (the zone plate: its closed form), and POV-Ray's own
# antialiasing (+A0.0 +AMm +Rr) at the final size; times, errors, high-pass
# shares, overshoot; charts, tables, images. Report: $(OUT)/report/index.html,
# results.json, *.csv, README-results.md, compare/ (charts and images);
# QUICK=1: small sizes, three scenes, $(OUT)/report-quick/, a minute or two.
# Renders are make render targets in $(OUT)/compare (QUICK:
# $(OUT)/compare-quick; POV-Ray's antialiasing in its pov-aa/NAME/), timed
# COMPARE_REPEATS times when under 3 s (RENDER_REPEATS); images and measures
# are kept beside them and remade only when what they were made from changes.
# COMPARE_* variables override the sizes: COMPARE_SCENES, COMPARE_RES,
# COMPARE_FACTORS, COMPARE_REF_FACTOR, COMPARE_AA, COMPARE_BORDER,
# COMPARE_REPEATS (timing runs, smallest kept).
ifneq ($(QUICK),)
COMPARE_SCENES     ?= checker edges zoneplate
COMPARE_RES        ?= 64
COMPARE_FACTORS    ?= 1 2 4
COMPARE_REF_FACTOR ?= 8
COMPARE_AA         ?= am1-r2 am2-r2
COMPARE_REPEATS    ?= 1
COMPARE_LABEL      := quick
COMPARE_WORK       ?= $(OUT)/compare-quick
COMPARE_REPORT     ?= $(OUT)/report-quick
else
COMPARE_SCENES     ?= checker objects edges hdr zoneplate
COMPARE_RES        ?= 256
COMPARE_FACTORS    ?= 1 2 3 4 6 8
COMPARE_REF_FACTOR ?= 32
COMPARE_AA         ?= am1-r2 am1-r3 am1-r4 am2-r1 am2-r2 am2-r3 am2-r4
COMPARE_REPEATS    ?= 3
COMPARE_LABEL      := full
COMPARE_WORK       ?= $(OUT)/compare
COMPARE_REPORT     ?= $(OUT)/report
endif
COMPARE_BORDER     ?= 4
.PHONY: compare
compare: $(if $(PREBUILT),,build)
	@test -x $(PYTHON) || { echo "compare: $(PYTHON) not found: run scripts/setup.sh (make setup)" >&2; exit 1; }
	@$(PYTHON) scripts/compare.py --work $(COMPARE_WORK) --report $(COMPARE_REPORT) --label $(COMPARE_LABEL) \
	  --scenes '$(COMPARE_SCENES)' --scenedir $(SCENEDIR) --res $(COMPARE_RES) \
	  --factors '$(COMPARE_FACTORS)' --ref-factor $(COMPARE_REF_FACTOR) --aa '$(COMPARE_AA)' \
	  --border $(COMPARE_BORDER) --cutoffs '$(CUTOFFS)' --repeats $(COMPARE_REPEATS) \
	  --zp-nyquist $(ZP_NYQUIST) \
	  $(foreach m,$(METHODS),--method '$(m)=$(METHOD_OPTS_$(m))')
# make compare-hex [QUICK=1]: the hexagonal lattice against the Cartesian one
# (scripts/compare_hex.py): the smooth analytic image, the zone plate (whole
# frame and inscribed disk), objects and edges; hex hat and quartic at several
# densities against the tent and cubic at one coefficient per pixel, factors
# 2, 4 and 8; the density where they meet; renders: make render targets in
# $(OUT)/compare-hex[-quick]. $(OUT)/report/hex/ (QUICK:
# $(OUT)/report-quick/hex/, 64 x 64, factors 2 and 4, about 15 s).
.PHONY: compare-hex
compare-hex: $(if $(PREBUILT),,build)
	@test -x $(PYTHON) || { echo "compare-hex: $(PYTHON) not found: run scripts/setup.sh (make setup)" >&2; exit 1; }
	@$(PYTHON) scripts/compare_hex.py --work $(OUT)/compare-hex$(if $(QUICK),-quick) \
	  --report $(OUT)/$(if $(QUICK),report-quick,report)/hex \
	  $(if $(QUICK),--res 64 --factors "2 4" --ref-factor 8 --spp 8 --border 8)
# make compare-mip [QUICK=1]: pyramids against maketx (scripts/compare_mip.py):
# objects, zoneplate and checker from a render at factor 8 of a 1024 x 1024
# frame, levels 0 to 5 by siproject (box, tent, cubic; centred and 2x2)
# against maketx's levels of the same render (box, lanczos3, lanczos3
# --hicomp) and splineops' least-squares cubic resize of it to each level's
# size (scripts/splineops_resize.py; measured in its own, endpoint-aligned
# geometry): continuous L2
# error against the truth (a render at MIP_REF_FACTOR, 32 unless given: a
# 32768 x 32768 render a scene; the zone plate's closed form), the
# displayed level against the truth's area averages, negative samples, time
# and peak memory of the whole pyramid. $(OUT)/report/mip/ (QUICK:
# $(OUT)/report-quick/mip-objects/ and mip-zoneplate/, objects at 128 x 128
# and zoneplate at 256 x 256, one timing run each).
MIP_REF_FACTOR ?= 32
.PHONY: compare-mip
compare-mip: $(if $(PREBUILT),,build)
	@test -x $(PYTHON) || { echo "compare-mip: $(PYTHON) not found: run scripts/setup.sh (make setup)" >&2; exit 1; }
ifneq ($(QUICK),)
	@$(PYTHON) scripts/compare_mip.py --scenes objects --res 128 --repeat 1 --out $(OUT) \
	  --siproject $(BUILD)/tools/siproject --work $(OUT)/compare-mip-quick --report $(OUT)/report-quick/mip-objects
	@$(PYTHON) scripts/compare_mip.py --scenes zoneplate --res 256 --repeat 1 --out $(OUT) \
	  --siproject $(BUILD)/tools/siproject --work $(OUT)/compare-mip-quick --report $(OUT)/report-quick/mip-zoneplate
else
	@$(PYTHON) scripts/compare_mip.py --out $(OUT) --siproject $(BUILD)/tools/siproject \
	  --work $(OUT)/compare-mip --report $(OUT)/report/mip --ref-factor $(MIP_REF_FACTOR)
endif
# make compare-samples [QUICK=1]: the sample patterns compared
# (scripts/compare_samples.py): every scene, pattern, density and seed
# rendered as make's render targets (make render SAMPLES=... in
# $(CS_WORK)), each method's L2 error against the truth, its displayed
# image's error, the high-pass share, their spread across seeds, and each
# render's wall time (scripts/timed_make.sh: .NAME.seconds beside a render,
# written when make made it). The reference's own grid: on CS_REF_CHECK
# (a scene, or empty for none) the errors also against a regular reference at
# CS_REF_ALT_FACTOR and a jittered one (seed 0) at CS_REF_FACTOR. Report:
# $(OUT)/report/samples/ (QUICK: $(OUT)/report-quick/samples/, 64 x 64,
# 4 and 16 rays per pixel, 2 seeds, three scenes).
ifneq ($(QUICK),)
CS_SCENES    ?= checker edges zoneplate
CS_RES       ?= 64
CS_FACTORS   ?= 2 4
CS_SEEDS     ?= 0 1
CS_REF_FACTOR ?= 8
CS_REF_ALT_FACTOR ?= 4
else
CS_SCENES    ?= checker objects edges zoneplate
CS_RES       ?= 256
CS_FACTORS   ?= 1.41421356 2 2.82842712 4
CS_SEEDS     ?= 0 1 2 3
CS_REF_FACTOR ?= 32
CS_REF_ALT_FACTOR ?= 16
endif
CS_REF_CHECK ?= checker
# The share of the references' samples the sampled check evaluates: at
# factor 32 a sixteenth is 4.2 M samples, whose mean square is within a few
# tenths of a percent of the whole set's (about sqrt(2/N) relative for errors
# that are not concentrated in a few samples).
CS_CHECK_SHARE ?= $(if $(QUICK),1,0.0625)
CS_WORK ?= $(OUT)/compare-samples$(if $(QUICK),-quick)
CS_MAKE = $(MAKE) --no-print-directory SIPROJECT=$(SIPROJECT) SIMETRICS=$(SIMETRICS) SIRAYS=$(SIRAYS) \
  OUT=$(CS_WORK) RES=$(CS_RES) ZP_NYQUIST=$(ZP_NYQUIST)
.PHONY: compare-samples
compare-samples: $(if $(PREBUILT),,build)
	@set -e; r=$(CS_WORK)/render; \
	for s in $(CS_SCENES); do \
	  [ $$s = zoneplate ] || $(CS_MAKE) SCENE=$$s FACTOR=$(CS_REF_FACTOR) render; \
	  for f in $(CS_FACTORS); do \
	    bash scripts/timed_make.sh $$r/$$s-$(CS_RES)-f$$f.exr $(CS_MAKE) SCENE=$$s FACTOR=$$f render; \
	    for p in jitter sobol; do for k in $(CS_SEEDS); do \
	      bash scripts/timed_make.sh $$r/$$s-$(CS_RES)-f$$f-$$p-s$$k.exr \
	        $(CS_MAKE) -j$(JOBS) SCENE=$$s FACTOR=$$f SAMPLES=$$p SEED=$$k render; \
	    done; done; \
	  done; \
	done; \
	for s in $(CS_REF_CHECK); do \
	  $(CS_MAKE) SCENE=$$s FACTOR=$(CS_REF_ALT_FACTOR) render; \
	  $(CS_MAKE) -j$(JOBS) SCENE=$$s FACTOR=$(CS_REF_FACTOR) SAMPLES=jitter SEED=0 render; \
	done
	@$(PYTHON) scripts/compare_samples.py --work $(CS_WORK) --report $(OUT)/$(if $(QUICK),report-quick,report)/samples \
	  --scenes '$(CS_SCENES)' --res $(CS_RES) --factors '$(CS_FACTORS)' --seeds '$(CS_SEEDS)' \
	  --ref-factor $(CS_REF_FACTOR) --ref-check '$(CS_REF_CHECK)' --ref-alt-factor $(CS_REF_ALT_FACTOR) \
	  --check-share $(CS_CHECK_SHARE) --zp-nyquist $(ZP_NYQUIST)
# ==== end of comparison ========================================================

# ---- bench: siproject against oiiotool, splineops and the decode floor ---------
# make bench [QUICK=1]: out/bench/bench.md and bench.csv (scripts/bench.py);
# the input renders (objects at 8000^2, checker at 16000^2, and objects at
# 500^2 output pixels, factor 4, regular and jitter: the scattered rows) are
# make render targets in $(OUT)/bench/render, made once;
# make docs copies the table into docs/performance.md. BENCHFLAGS: more
# options (--runs 5, --wait-idle 30, --no-big; scripts/bench.py --help).
BENCHFLAGS ?=
.PHONY: bench microbench
bench: $(if $(PREBUILT),,build)
	@$(PYTHON) scripts/bench.py --build $(BUILD) --outdir $(OUT)/bench --siproject $(SIPROJECT) $(if $(QUICK),--quick) $(BENCHFLAGS)

# Google Benchmark microbenchmarks of acquisition, prefilter and resampling.
microbench: $(if $(PREBUILT),,build)
	@$(BUILD)/tests/microbench

# ==== docs: the committed snapshots ===========================================
# make docs: docs/studies.md's results and docs/img/error-vs-time.png from
# the last full make compare, docs/performance.md's table from the last make
# bench, docs/img/methods.png (the README's picture) from the default scene's
# images (make). Only this target writes tracked files; each part is skipped,
# with a note, when its report is missing.
.PHONY: docs
docs:
	@if [ -f $(OUT)/report/README-results.md ]; then \
	  $(PYTHON) scripts/readme_section.py docs/studies.md results $(OUT)/report/README-results.md 1 && \
	  cp $(OUT)/report/compare/charts/error-vs-time.png docs/img/error-vs-time.png && \
	  echo "docs: docs/studies.md results and docs/img/error-vs-time.png from $(OUT)/report"; \
	else echo "docs: no $(OUT)/report/README-results.md (run make compare): results left as they are"; fi
	@if [ -f $(OUT)/bench/bench.md ]; then \
	  $(PYTHON) scripts/readme_section.py docs/performance.md performance $(OUT)/bench/bench.md 2 && \
	  echo "docs: docs/performance.md table from $(OUT)/bench/bench.md"; \
	else echo "docs: no $(OUT)/bench/bench.md (run make bench): table left as it is"; fi
	@if [ -f $(OUT)/report/samples/samples.png ]; then \
	  cp $(OUT)/report/samples/samples.png docs/img/samples.png && \
	  cp $(OUT)/report/samples/samples-time.png docs/img/samples-time.png && \
	  echo "docs: docs/img/samples.png and samples-time.png from $(OUT)/report/samples (the numbers in docs/studies.md are written by hand)"; \
	else echo "docs: no $(OUT)/report/samples (run make compare-samples): charts left as they are"; fi
	@if [ -f $(OUT)/report/adaptive/adaptive.png ]; then \
	  cp $(OUT)/report/adaptive/adaptive.png docs/img/adaptive.png && \
	  echo "docs: docs/img/adaptive.png from $(OUT)/report/adaptive (the numbers in docs/studies.md are written by hand)"; \
	else echo "docs: no $(OUT)/report/adaptive (run make compare-adaptive): chart left as it is"; fi
	@if [ -f $(OUT)/report/anim/psnr-vs-k.png ]; then \
	  cp $(OUT)/report/anim/psnr-vs-k.png docs/img/anim-psnr-vs-k.png && \
	  echo "docs: docs/img/anim-psnr-vs-k.png from $(OUT)/report/anim (the numbers in docs/studies.md are written by hand)"; \
	else echo "docs: no $(OUT)/report/anim (run make compare-anim): chart left as it is"; fi
	@if [ -f $(OUT)/checker/me-cubic-2x2.png ]; then \
	  $(PYTHON) scripts/docs_picture.py $(OUT)/checker docs/img/methods.png && \
	  echo "docs: docs/img/methods.png from $(OUT)/checker"; \
	else echo "docs: no $(OUT)/checker images (run make): picture left as it is"; fi

# make compare-anim [QUICK=1]: the animation study (scripts/compare_anim.py):
# the sweep (scenes/sweep.pov, known in closed form at every time) as a slow
# and a fast zone plate and slow bars, K = 2, 4, 8 sub-frames a frame at
# 24 fps (make anim-subframes in $(OUT)/compare-anim), the sub-frame average
# and space-time min-error of degrees 0, 1, 3 against the shutter's exact
# integral, shutters of 180 and 360 degrees; frame-rate conversion 24 <-> 60
# fps; siproject --fps's time and memory. $(OUT)/report/anim/ (QUICK:
# $(OUT)/report-quick/anim/, 32 x 32, the slow zone plate, K = 2 and 4).
.PHONY: compare-anim
compare-anim: $(if $(PREBUILT),,build)
	@PYTHONPATH=$(BUILD)/python $(PYTHON) scripts/compare_anim.py --work $(OUT)/compare-anim$(if $(QUICK),-quick) \
	  --report $(OUT)/report$(if $(QUICK),-quick)/anim --siproject $(SIPROJECT) --jobs $(JOBS) \
	  --zp-nyquist $(ZP_NYQUIST) $(if $(QUICK),--quick)

# make compare-sparse [QUICK=1]: fewer rays than pixels (docs/studies.md):
# the variational rule, the fit, the normalised sum and scipy's griddata of
# sobol rays at 0.25, 0.5 and 1 ray per pixel, against the conventional tent
# of the regular factor-1 render; the continuous L2 error against the
# regular reference at SP_REF_FACTOR. $(OUT)/report(-quick)/sparse/sparse.md,
# sparse.csv. QUICK=1: objects at 128^2, reference factor 16.
ifneq ($(QUICK),)
SP_SCENES ?= objects
SP_RES ?= 128
SP_REF_FACTOR ?= 16
else
SP_SCENES ?= objects checker edges hdr
SP_RES ?= 256
SP_REF_FACTOR ?= 32
endif
SP_SEED ?= 0
SP_WORK ?= $(OUT)/compare-sparse$(if $(QUICK),-quick)
SP_MAKE = $(MAKE) --no-print-directory SIPROJECT=$(SIPROJECT) SIMETRICS=$(SIMETRICS) SIRAYS=$(SIRAYS) \
  OUT=$(SP_WORK) RES=$(SP_RES) ZP_NYQUIST=$(ZP_NYQUIST)
.PHONY: compare-sparse
compare-sparse: $(if $(PREBUILT),,build)
	@set -e; for s in $(SP_SCENES); do \
	  $(SP_MAKE) SCENE=$$s FACTOR=$(SP_REF_FACTOR) render; \
	  $(SP_MAKE) SCENE=$$s FACTOR=1 render; \
	  for f in 0.5 0.70710678 1; do \
	    $(SP_MAKE) -j$(JOBS) SCENE=$$s FACTOR=$$f SAMPLES=sobol SEED=$(SP_SEED) render; \
	  done; \
	done
	@PYTHONPATH=$(BUILD)/python $(PYTHON) scripts/compare_sparse.py --work $(SP_WORK) \
	  --report $(OUT)/report$(if $(QUICK),-quick)/sparse --scenes "$(SP_SCENES)" --res $(SP_RES) \
	  --ref-factor $(SP_REF_FACTOR) --seed $(SP_SEED)

# make compare-adaptive [QUICK=1]: adaptive rays (docs/studies.md): the
# estimators against the oracle (per-tile error of min-error cubic) and the
# L2 error against rays per pixel of uniform sobol rays and adaptive ones,
# every set a subset of the sobol render of 64 rays per pixel
# (scripts/compare_adaptive.py); the variational rule of uniform sobol rays
# from 0.25 to 4 rays per pixel (sobol renders at FACTOR 0.5 and 0.70710678
# below one ray per pixel); POV-Ray's own adaptive antialiasing
# (+AM1/+AM2 at several thresholds and depths, renders of their own under
# $(AD_WORK)/pov-aa/) at its rays per pixel; every row's displayed error too;
# and make SAMPLES=adaptive RAYS=16's own two passes measured, the second
# also as rectangular partial renders (AD_RECT_SCENES).
# $(OUT)/report(-quick)/adaptive/adaptive.md, adaptive.csv, estimators.csv,
# adaptive.png. QUICK=1: objects and edges at 128^2, reference factor 16;
# the full study adds hdr, checker and the zone plate (its closed form the
# truth) at 256^2, reference factor 32.
ifneq ($(QUICK),)
AD_SCENES ?= objects edges
AD_RES ?= 128
AD_REF_FACTOR ?= 16
else
AD_SCENES ?= objects hdr checker edges zoneplate
AD_RES ?= 256
AD_REF_FACTOR ?= 32
endif
AD_WORK ?= $(OUT)/compare-adaptive$(if $(QUICK),-quick)
# the scenes whose second pass is also timed as rectangular partial renders
# (scripts/rect_pass.py: a POV-Ray process per refined tile, and per run of
# adjacent tiles), rectangles-SCENE.md beside adaptive.md
AD_RECT_SCENES ?= objects
AD_MAKE = $(MAKE) --no-print-directory SIPROJECT=$(SIPROJECT) SIMETRICS=$(SIMETRICS) SIRAYS=$(SIRAYS) \
  OUT=$(AD_WORK) RES=$(AD_RES) ZP_NYQUIST=$(ZP_NYQUIST)
.PHONY: compare-adaptive
compare-adaptive: $(if $(PREBUILT),,build)
	@set -e; for s in $(AD_SCENES); do \
	  [ $$s = zoneplate ] || $(AD_MAKE) SCENE=$$s FACTOR=$(AD_REF_FACTOR) render; \
	  for f in 0.5 0.70710678 2 4 8; do $(AD_MAKE) -j$(JOBS) SCENE=$$s FACTOR=$$f SAMPLES=sobol SEED=0 render; done; \
	  $(AD_MAKE) SCENE=$$s SAMPLES=adaptive RAYS=16 SEED=0 METHODS=me-cubic scene >/dev/null; \
	done
	@PYTHONPATH=$(BUILD)/python $(PYTHON) scripts/compare_adaptive.py --work $(AD_WORK) \
	  --report $(OUT)/report$(if $(QUICK),-quick)/adaptive --scenes "$(AD_SCENES)" --res $(AD_RES) \
	  --ref-factor $(AD_REF_FACTOR) --seed 0 --sirays $(SIRAYS) --siproject $(SIPROJECT) \
	  --zp-nyquist $(ZP_NYQUIST)
	@set -e; for s in $(AD_RECT_SCENES); do \
	  case " $(AD_SCENES) " in *" $$s "*) ;; *) echo "compare-adaptive: AD_RECT_SCENES: $$s is not in AD_SCENES ($(AD_SCENES)): it has no refinement" >&2; exit 2;; esac; \
	  $(PYTHON) scripts/rect_pass.py --refinement $(AD_WORK)/render/$$s-$(AD_RES)-adaptive-r16-s0.refine.txt \
	    --scene $(SCENEDIR)/$$s.pov --povopts "$$([ $$s = zoneplate ] && awk 'BEGIN { printf "Declare=ZP_K=%.6f", $(ZP_NYQUIST) * atan2(0, -1) * $(AD_RES) }')" \
	    --out $(OUT)/report$(if $(QUICK),-quick)/adaptive/rectangles-$$s.md; done
