"""The book's studies: one module per study, each reading what the concepts and evaluations measure.

A study asks a question of the library that neither paper asks (which decoder trains in minutes, how sJPE answers
to noise, how far bf16 moves the numbers) and lays the answer out as tables, figures and sentences. It sits above the
concept packages and :mod:`motionlab.evaluation`, and may read :mod:`motionlab.report`; nothing below imports it.

==========================  ==========================================================================================
module                      study
==========================  ==========================================================================================
``toy_flow``                chapter 03: energy distance by sampler budget on the toy flow
``ablation``                chapter 04: the condition-projection ablation
``reconstruction``          chapter 05: Table 1's clips as joints, the typical clip, the cost of decoding a split
``sweep``                   "Choosing a decoder that trains in minutes": the recorded DisCoRD decoder sweep
``sjpe_sensitivity``        chapter 06: sJPE, FID and joint shift against frame noise and smoothing
``tokenizer_analysis``      chapter 02: the tokenizers' configs, codebook use, errors and jerk as tables
``diffusion_diagnostics``   chapters 07-08: the x_0 entropy table, the forward processes' distance per η
``transitions``             chapter 09: the transition Jerk at each boundary of one example
``precision_parity``        "bf16 against fp32": the recorded parity runs
``retraining``              "Retraining and the verdicts": each training run's difference against the mean
``scale``                   chapter 99: the scale study's points trained, scored and planned (``experiments/scale.py``)
``departures``              "Where the laptop departs from the papers": each departure and the verdicts it moves
==========================  ==========================================================================================

The training-seed, budget and η studies feed the claims table's verdicts, so they are read by
:mod:`motionlab.report` (``spread``, ``budget``), and what each of them trains and scores is defined by
:mod:`motionlab.evaluation.studies`, below it; the scale study's points likewise by :mod:`motionlab.evaluation.scale`
(read by :mod:`motionlab.report.scale`).
"""
