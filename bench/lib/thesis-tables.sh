# Sourced by the observer scripts: the thesis's five published vote tables, each with the
# experiment it forecasts and the clips it needs.
#
# thesis_table TABLE sets table_views (mono or stereo), table_only (the `--only` filter of its
# clips), table_experiment (experiments/NAME.toml) and table_votes (analysis/reference/NAME.csv)
# for TABLE, one of $thesis_tables; any other name is refused (status 2, named on stderr).

thesis_tables="5.6.3 5.7.2 6.5.2-sampling 6.5.2-shutter 6.6.2"

thesis_table() {
  case $1 in
    5.6.3) table_views=mono table_only="M3 S2 T3 *" table_experiment=mono-2-sampling-2afc \
      table_votes=thesis-5.6.3-mono-sampling-2afc ;;
    5.7.2) table_views=mono table_only="M2 S2 T3-T5 A3-A5" table_experiment=mono-3-interactions \
      table_votes=thesis-5.7.2-mono-interactions ;;
    6.5.2-sampling) table_views=stereo table_only="M3 S2 T3 *" table_experiment=stereo-2-sampling \
      table_votes=thesis-6.5.2-stereo-sampling ;;
    6.5.2-shutter) table_views=stereo table_only="M3 S2 * A5" table_experiment=stereo-2-shutter \
      table_votes=thesis-6.5.2-stereo-shutter ;;
    6.6.2) table_views=stereo table_only="M2 S2 T3-T5 A3-A5" table_experiment=stereo-3-interactions \
      table_votes=thesis-6.6.2-stereo-interactions ;;
    *) echo "unknown table $1 (one of: $thesis_tables)" >&2; return 2 ;;
  esac
}
