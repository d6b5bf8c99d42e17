#!/usr/bin/env Rscript
# ranger (extremely randomized trees) on an exported corpus (train-forest --export-corpus), the peer
# of forest-peers: splitrule "extratrees" with num.random.splits = 1, every column tried (mtry = ncol),
# no bootstrap (replace = FALSE, sample.fraction = 1), min.node.size = 5, 7 trees. Times the fit only,
# wall clock and process CPU (medians of --repeat fits), then predicts the held-out rows.
# Usage: ranger_peer.R TRAIN.csv HELDOUT.csv [--trees 7] [--min-node-size 5] [--seeds 1,2,3]
#                      [--repeat 3] [--threads 1] [--probability] [-o result.json]
# Default (classification forest): each leaf votes its majority class, the forest takes the majority
# vote (ranger breaks ties at random). --probability: a probability forest, which sums the trees'
# leaf distributions like ours and scikit-learn's (argmax, lowest class on ties).
# Memory (Linux): the peak RSS of the whole process (peak_rss_mb, reading the CSVs and building the
# data.frames included) and of the fits alone (fit_peak_rss_mb: before each fit the previous forest is
# dropped, gc() runs, and the peak is reset to the current RSS, rss_before_fit_mb, by writing 5 to
# /proc/self/clear_refs; it is read after the fit). MB = 2^20 bytes.
suppressPackageStartupMessages(library(ranger))

fail <- function(msg) {
  cat("ranger_peer: error:", msg, "\n", file = stderr())
  quit(status = 1)
}

args <- commandArgs(trailingOnly = TRUE)
opt <- list(trees = 7L, min_node_size = 5L, seeds = "1", repeat_ = 3L, threads = 1L, probability = FALSE, out = "")
pos <- character(0)
i <- 1
while (i <= length(args)) {
  a <- args[i]
  val <- function() { if (i + 1 > length(args)) fail(paste(a, "needs a value")); args[i + 1] }
  if (a %in% c("-M", "--trees")) { opt$trees <- as.integer(val()); i <- i + 1 }
  else if (a == "--min-node-size") { opt$min_node_size <- as.integer(val()); i <- i + 1 }
  else if (a == "--seeds") { opt$seeds <- val(); i <- i + 1 }
  else if (a == "--repeat") { opt$repeat_ <- as.integer(val()); i <- i + 1 }
  else if (a == "--threads") { opt$threads <- as.integer(val()); i <- i + 1 }
  else if (a == "--probability") { opt$probability <- TRUE }
  else if (a %in% c("-o", "--out")) { opt$out <- val(); i <- i + 1 }
  else if (startsWith(a, "-")) fail(paste("unknown option", a))
  else pos <- c(pos, a)
  i <- i + 1
}
if (length(pos) != 2) fail("usage: ranger_peer.R TRAIN.csv HELDOUT.csv [options]")

read_corpus <- function(path) {
  if (!file.exists(path)) fail(paste0(path, ": cannot be read"))
  header <- readLines(path, n = 1)
  if (!startsWith(header, "label,")) fail(paste0(path, ": header: expected 'label,<candidate names>'"))
  d <- scan(path, what = numeric(), sep = ",", skip = 1, quiet = TRUE)
  nc <- lengths(regmatches(header, gregexpr(",", header))) + 1
  if (length(d) %% nc != 0) fail(paste0(path, ": rows do not all have ", nc, " fields"))
  m <- matrix(d, ncol = nc, byrow = TRUE)
  x <- m[, -1, drop = FALSE]
  colnames(x) <- paste0("c", seq_len(ncol(x)))  # the candidate names are not valid R names
  list(header = header, x = x, y = as.integer(m[, 1]))
}

tr <- read_corpus(pos[1])
he <- read_corpus(pos[2])
if (tr$header != he$header) fail(paste0(pos[2], ": header differs from ", pos[1], "'s: the corpora must share their columns"))
# The data.frame interface (dependent.variable.name): in ranger 0.14 the x/y interface spends ~2 s
# more per fit converting 2400 columns, which would not be a fair measure of its trainer.
train_df <- data.frame(label = factor(tr$y), tr$x, check.names = FALSE)
held_df <- data.frame(he$x, check.names = FALSE)
seeds <- as.integer(strsplit(opt$seeds, ",")[[1]])
# VmHWM and VmRSS of this process in kB (NULL without /proc).
rss_status <- function() {
  l <- tryCatch(readLines("/proc/self/status"), error = function(e) NULL, warning = function(w) NULL)
  if (is.null(l)) return(NULL)
  get <- function(key) as.numeric(strsplit(trimws(sub(paste0("^", key, ":"), "", grep(paste0("^", key, ":"), l, value = TRUE))), " +")[[1]][1])
  c(hwm = get("VmHWM"), rss = get("VmRSS"))
}
reset_peak <- function() tryCatch({ writeLines("5", "/proc/self/clear_refs"); TRUE },
                                  error = function(e) FALSE, warning = function(w) FALSE)
peak_kb <- 0
fit_peaks <- numeric(0)
before_fit <- numeric(0)
runs <- list()
for (seed in seeds) {
  times <- numeric(0)
  cpu_times <- numeric(0)
  for (r in seq_len(opt$repeat_)) {
    if (exists("fit")) rm(fit)
    invisible(gc())
    st <- rss_status()
    measured <- !is.null(st) && reset_peak()
    if (measured) {
      peak_kb <- max(peak_kb, st[["hwm"]])
      before_fit <- c(before_fit, rss_status()[["rss"]])
    }
    t0 <- proc.time()
    fit <- ranger(dependent.variable.name = "label", data = train_df, num.trees = opt$trees, splitrule = "extratrees", num.random.splits = 1,
                  replace = FALSE, sample.fraction = 1, mtry = ncol(tr$x), min.node.size = opt$min_node_size,
                  probability = opt$probability, num.threads = opt$threads, seed = seed,
                  verbose = FALSE)
    t1 <- proc.time()
    times <- c(times, t1[["elapsed"]] - t0[["elapsed"]])
    cpu_times <- c(cpu_times, (t1[["user.self"]] + t1[["sys.self"]]) - (t0[["user.self"]] + t0[["sys.self"]]))
    if (measured) fit_peaks <- c(fit_peaks, rss_status()[["hwm"]])
  }
  p <- predict(fit, data = held_df, num.threads = opt$threads)$predictions
  pred <- if (opt$probability) as.integer(colnames(p)[max.col(p, ties.method = "first")]) else as.integer(as.character(p))
  acc <- mean(pred == he$y)
  cls <- sort(unique(he$y))
  class_avg <- mean(sapply(cls, function(k) mean(pred[he$y == k] == k)))
  nodes <- sum(sapply(fit$forest$child.nodeIDs, function(t) length(t[[1]])))
  sec <- median(times)
  cpu <- median(cpu_times)
  runs[[length(runs) + 1]] <- list(seed = seed, accuracy = acc, class_average = class_avg, seconds = sec,
                                   seconds_all = times, cpu_seconds = cpu, cpu_seconds_all = cpu_times, nodes = nodes)
  cat(sprintf("seed %d: accuracy %.4f, fit %.4f s wall, %.4f s CPU (medians of %d), %d nodes\n", seed, acc, sec, cpu,
              opt$repeat_, nodes))
  flush(stdout())
}
mean_acc <- mean(sapply(runs, function(r) r$accuracy))
med_sec <- median(sapply(runs, function(r) r$seconds))
med_cpu <- median(sapply(runs, function(r) r$cpu_seconds))
st <- rss_status()
mb <- function(kb) round(kb / 1024, 1)
if (!is.null(st) && length(fit_peaks)) {
  rss_json <- sprintf(', "peak_rss_mb": %.1f, "fit_peak_rss_mb": %.1f, "rss_before_fit_mb": %.1f, "rss_method": "%s"',
                      mb(max(peak_kb, st[["hwm"]])), mb(max(fit_peaks)), mb(max(before_fit)),
                      "inside: /proc/self/status VmHWM, reset (clear_refs 5) before each fit, after gc()")
  rss_text <- sprintf("; peak RSS %.1f MB (process), %.1f MB (fit)", mb(max(peak_kb, st[["hwm"]])), mb(max(fit_peaks)))
} else {
  rss_json <- ', "peak_rss_mb": null, "fit_peak_rss_mb": null, "rss_before_fit_mb": null'
  rss_text <- ""
}
cat(sprintf("mean accuracy %.4f over %d seeds, median fit %.4f s wall, %.4f s CPU%s\n", mean_acc, length(runs), med_sec, med_cpu, rss_text))

if (nzchar(opt$out)) {
  num <- function(v) paste0("[", paste(sprintf("%.6g", v), collapse = ", "), "]")
  run_json <- sapply(runs, function(r) sprintf(
    '{"seed": %d, "accuracy": %.6f, "class_average": %.6f, "seconds": %.6g, "seconds_all": %s, "cpu_seconds": %.6g, "cpu_seconds_all": %s, "nodes": %d}',
    r$seed, r$accuracy, r$class_average, r$seconds, num(r$seconds_all), r$cpu_seconds, num(r$cpu_seconds_all), as.integer(r$nodes)))
  tool <- paste0("ranger ", as.character(packageVersion("ranger")), if (opt$probability) " (probability forest)" else " (classification forest)")
  json <- sprintf(paste0('{"tool": "%s", "train": "%s", "heldout": "%s", "rows_train": %d, "rows_heldout": %d, ',
                         '"columns": %d, "trees": %d, "min_node_size": %d, "threads": %d, "probability": %s, "repeat": %d, ',
                         '"runs": [%s], "mean_accuracy": %.6f, "median_seconds": %.6g, "median_cpu_seconds": %.6g%s}\n'),
                  tool, pos[1], pos[2], nrow(tr$x), nrow(he$x), ncol(tr$x), opt$trees, opt$min_node_size, opt$threads,
                  if (opt$probability) "true" else "false", opt$repeat_, paste(run_json, collapse = ", "), mean_acc, med_sec, med_cpu, rss_json)
  tmp <- paste0(opt$out, ".tmp")
  writeLines(json, tmp, sep = "")
  invisible(file.rename(tmp, opt$out))
}
