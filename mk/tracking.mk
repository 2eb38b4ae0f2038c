# Whisker tracking (issue 6). See docs/tracking.md.
#   make track SOURCE=clip.mp4             track a video (or SOURCE=picamera, 0, a folder) -> exports/tracks.csv
#   make track-demo                        track 100 synthetic frames, write CSV and an annotated video
#   make track-real                        the authors' real frames (needs WHISKER_PEER_DATA)
#   make bench-tracking                    only the tracking accuracy-vs-time benchmark
#   make bench-subpixel                    gain of the sub-pixel trackers on small rendered steps (~3 min)
SOURCE ?= synthetic:100
TRACK_OUT ?= $(OUT)/tracking

.PHONY: track track-demo track-real bench-tracking bench-subpixel

track: $(BIN)/.installed ## track markers of SOURCE (picamera, camera index, video, folder) -> exports/tracking/tracks.csv
	$(BIN)/whisker track $(DESIGN_ARGS) --source $(SOURCE) --out $(TRACK_OUT)/tracks.csv

track-demo: $(BIN)/.installed ## synthetic demo: tracks.csv + annotated.mp4 in exports/tracking/
	$(BIN)/whisker track $(DESIGN_ARGS) --source synthetic:100 --out $(TRACK_OUT)/demo.csv --record $(TRACK_OUT)/demo.mp4

track-real: $(BIN)/.installed ## the authors' actuated frame against their rest frame (needs WHISKER_PEER_DATA)
	@test -n "$(WHISKER_PEER_DATA)" || { echo "set WHISKER_PEER_DATA to the authors' data folder (docs/tracking.md)"; exit 2; }
	$(BIN)/whisker track $(DESIGN_ARGS) --source $(WHISKER_PEER_DATA)/img/actuated.jpg \
		--rest $(WHISKER_PEER_DATA)/img/org.jpg --rest-frames 1 \
		--calibration $(WHISKER_PEER_DATA)/img/calibration_data.npz --mask $(WHISKER_PEER_DATA)/img/polygonMask.png \
		--out $(TRACK_OUT)/real.csv --record $(TRACK_OUT)/real.mp4

bench-tracking: $(BIN)/.installed ## tracking methods: RMS error vs ms/frame at several noise levels
	$(BIN)/python benchmarks/bench_tracking.py

bench-subpixel: $(BIN)/.installed ## tracker gain (tracked / true step) on 0.005-0.5 px rendered steps -> benchmarks/results/subpixel.md
	$(BIN)/python benchmarks/bench_subpixel.py
