# SPDX-License-Identifier: Apache-2.0
# gpio-sim helpers for guest scripts run by uml_run.sh (POSIX sh; source with
# `. "$EF_HIL_DIR/gpio_lib.sh"`). The kernel's gpio-sim (Documentation/admin-guide/gpio/
# gpio-sim.rst) makes simulated chips from configfs:
#   /sys/kernel/config/gpio-sim/NAME/            dev_name (ro, "gpio-sim.0"), live
#   /sys/kernel/config/gpio-sim/NAME/bank0/      chip_name (ro, "gpiochip0"), num_lines, label
#   .../bank0/lineN/name                         the line's name
#   .../bank0/lineN/hog/{name,direction}         a kernel hog: consumer name, input /
#                                                output-high / output-low
# and drives its lines from sysfs:
#   /sys/devices/platform/<dev_name>/<chip_name>/sim_gpioN/pull   pull-up | pull-down (rw)
#   /sys/devices/platform/<dev_name>/<chip_name>/sim_gpioN/value  the line's level (ro): the
#                                                driven value of a requested output, else the pull
# A released line's value goes back to its pull (gpio-sim's free()).

GSIM_CFS=/sys/kernel/config

# gsim_setup: configfs mounted at /sys/kernel/config (uml_run.sh's init mounts it already
# where the kernel has it); 1 if the kernel has no gpio-sim.
gsim_setup() {
    if [ ! -d "$GSIM_CFS/gpio-sim" ]; then
        grep -qw configfs /proc/filesystems || { echo "gsim_setup: no configfs in this kernel"; return 1; }
        mount -t configfs none "$GSIM_CFS" 2>/dev/null
    fi
    [ -d "$GSIM_CFS/gpio-sim" ] || { echo "gsim_setup: no gpio-sim in this kernel"; return 1; }
}

# gsim_dir NAME: the chip's configfs directory.
gsim_dir() {
    printf '%s\n' "$GSIM_CFS/gpio-sim/$1"
}

# gsim_chip NAME NLINES "NAME0 NAME1 ..." [HOG_OFFSET HOG_NAME]: make a live chip of NLINES
# lines with one bank, label NAME; line k gets the k-th word of the names ("-": no name); a
# hog (consumer HOG_NAME, output-high) holds HOG_OFFSET. Prints the device, /dev/gpiochipX.
gsim_chip() {
    [ $# -eq 3 ] || [ $# -eq 5 ] || { echo "usage: gsim_chip NAME NLINES NAMES [HOG_OFFSET HOG_NAME]" >&2; return 2; }
    _gd=$(gsim_dir "$1")
    mkdir "$_gd" && mkdir "$_gd/bank0" || { echo "gsim_chip: cannot make $_gd" >&2; return 1; }
    echo "$2" >"$_gd/bank0/num_lines" || return 1
    printf '%s' "$1" >"$_gd/bank0/label" || return 1
    _gi=0
    for _gn in $3; do
        if [ "$_gn" != - ]; then
            mkdir -p "$_gd/bank0/line$_gi" && printf '%s' "$_gn" >"$_gd/bank0/line$_gi/name" ||
                { echo "gsim_chip: naming line $_gi" >&2; return 1; }
        fi
        _gi=$((_gi + 1))
    done
    if [ $# -eq 5 ]; then
        mkdir -p "$_gd/bank0/line$4/hog" &&
            printf '%s' "$5" >"$_gd/bank0/line$4/hog/name" &&
            echo output-high >"$_gd/bank0/line$4/hog/direction" ||
            { echo "gsim_chip: hog on line $4" >&2; return 1; }
    fi
    echo 1 >"$_gd/live" || { echo "gsim_chip: $1 did not go live" >&2; return 1; }
    _gc=$(cat "$_gd/bank0/chip_name") && [ -n "$_gc" ] || return 1
    # devtmpfs makes the node; wait for it briefly (it is there at once on the HIL kernel).
    _gi=0
    while [ ! -c "/dev/$_gc" ] && [ $_gi -lt 100 ]; do
        sleep 0.01
        _gi=$((_gi + 1))
    done
    [ -c "/dev/$_gc" ] || { echo "gsim_chip: /dev/$_gc did not appear" >&2; return 1; }
    printf '/dev/%s\n' "$_gc"
}

# gsim_sysdir NAME: the chip's sysfs directory, /sys/devices/platform/<dev_name>/<chip_name>.
gsim_sysdir() {
    _gd=$(gsim_dir "$1")
    printf '/sys/devices/platform/%s/%s\n' "$(cat "$_gd/dev_name")" "$(cat "$_gd/bank0/chip_name")"
}

# gsim_pull NAME OFFSET pull-up|pull-down: drive an input line from the simulated outside.
gsim_pull() {
    case $3 in
    pull-up | pull-down) ;;
    *) echo "gsim_pull: '$3' is neither pull-up nor pull-down" >&2; return 2 ;;
    esac
    echo "$3" >"$(gsim_sysdir "$1")/sim_gpio$2/pull"
}

# gsim_value NAME OFFSET: print the line's level (0 or 1).
gsim_value() {
    cat "$(gsim_sysdir "$1")/sim_gpio$2/value"
}

# gsim_remove NAME: take the chip down and remove its configfs tree.
gsim_remove() {
    _gd=$(gsim_dir "$1")
    [ -d "$_gd" ] || return 0
    echo 0 >"$_gd/live" 2>/dev/null
    for _gl in "$_gd"/bank0/line*; do
        [ -d "$_gl/hog" ] && rmdir "$_gl/hog"
        [ -d "$_gl" ] && rmdir "$_gl"
    done
    rmdir "$_gd/bank0" "$_gd"
}
