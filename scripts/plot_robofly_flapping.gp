# Figure docs/figures/robofly_flapping_forces.svg from the CSV written by
# ImmersedConverged.DISABLED_FlappingRoboflyAdvanced (docs/validation.md, "Flapping wing"). Run from the
# repository root: gnuplot scripts/plot_robofly_flapping.gp
set terminal svg size 800,420 dynamic font "Helvetica,12"
set output 'docs/figures/robofly_flapping_forces.svg'
set datafile separator ','
set key outside right top
set xlabel 'phase of the wingbeat, tau (0 = dorsal reversal)'
set ylabel 'force coefficient, F / (rho U^2 S / 2)'
set title 'Flapping Robofly wing, advanced rotation, Re 136: CFD (c/16, 3rd wingbeat) vs quasi-steady model'
set grid
plot 'docs/figures/robofly_flapping_forces.csv' skip 2 using 1:2 with lines lw 2 lc rgb '#1f77b4' title 'C_L CFD', \
     '' skip 2 using 1:4 with lines lw 1.5 dt 2 lc rgb '#1f77b4' title 'C_L model', \
     '' skip 2 using 1:3 with lines lw 2 lc rgb '#d62728' title 'C_D CFD', \
     '' skip 2 using 1:5 with lines lw 1.5 dt 2 lc rgb '#d62728' title 'C_D model'
