; Problem 5 of Lagriffoul et al. 2018, the kitchen: a reconstruction (docs/benchmarks.md). The
; suite publishes no files for it; this domain follows the suite's blocksworld.pddl and
; clutter.pddl, with the two non-geometric actions of the paper's section VI-E.
(define (domain kitchen)
(:requirements :strips :typing)
(:types objs surface)
(:constants dishwasher stove - surface)
(:predicates (on-surface ?x - objs ?surf - surface)
             (arm-empty)
             (holding ?x - objs)
             (on ?x - objs ?y - objs)
             (clean ?x - objs)
             (cooked ?x - objs))

(:action pickup
  :parameters (?ob - objs ?surf - surface)
  :precondition (and (on-surface ?ob ?surf) (arm-empty))
  :effect (and (holding ?ob) (not (on-surface ?ob ?surf)) (not (arm-empty))))

(:action putdown
  :parameters (?ob - objs ?surf - surface)
  :precondition (holding ?ob)
  :effect (and (arm-empty) (on-surface ?ob ?surf) (not (holding ?ob))))

(:action stack
  :parameters (?ob - objs ?underob - objs)
  :precondition (holding ?ob)
  :effect (and (arm-empty) (on ?ob ?underob) (not (holding ?ob))))

(:action unstack
  :parameters (?ob - objs ?underob - objs)
  :precondition (and (on ?ob ?underob) (arm-empty))
  :effect (and (holding ?ob) (not (on ?ob ?underob)) (not (arm-empty))))

; non-geometric: an object on the dishwasher becomes clean
(:action clean
  :parameters (?x - objs)
  :precondition (on-surface ?x dishwasher)
  :effect (clean ?x))

; non-geometric: a clean object on the stove becomes cooked
(:action cook
  :parameters (?x - objs)
  :precondition (and (on-surface ?x stove) (clean ?x))
  :effect (cooked ?x)))
