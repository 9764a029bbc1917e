# The robot file (config/robots/datasets/) of each imported real recording, by its name
# (scripts/import-datasets.sh); sourced by the scripts that run over all of them.
# dataset_robot NAME: prints the file name, or fails for a recording without one.
dataset_robot() {
  case $1 in
    mit_csail) echo mit_csail.yaml ;;
    mines_*) echo mines_rover.yaml ;;
    lego_*) echo lego_robot.yaml ;;
    optiodom_tricycle_*) echo optiodom_tricycle.yaml ;;
    optiodom_diff_*) echo optiodom_diff.yaml ;;
    *) return 1 ;;
  esac
}
